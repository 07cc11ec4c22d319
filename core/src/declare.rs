//! The one declaration per kernel, and everything derived from it.
//!
//! [`kernel_table!`](crate::kernel_table) is invoked once, in `kernels::table`, with one entry per
//! kernel: its SPIR-V entry name, the function in core, workgroup size, push-constant type and
//! its bindings (name, access, element type). From each entry come
//! - the [`KernelDesc`](crate::executor::KernelDesc) static the backends read (bindings with names,
//!   element types and sizes, access),
//! - the CPU runner inside it (the native counterpart of the SPIR-V entry),
//! - a named bindings struct the plan code fills (`AtrousBindings { input, surfaces, .. }`) and
//!   turns into a [`Pass`](crate::executor::Pass),
//! - the `#[spirv(compute)]` entry point, emitted by the exported `spirv_entries!()` macro that
//!   `vrrt-shaders` expands once at its crate root,
//! - `kernels::ALL`, the list of every kernel.
//!
//! Three kinds of kernel are declared:
//! - `fn path`: one call per invocation, `f(id, &params, bindings..)`;
//! - `lanes(N) path`: one call per `N` invocations consecutive in x, `f::<N>(id of the first,
//!   &params, bindings..)` ([`crate::lanes`]); the SPIR-V entry calls `f::<1>`, the CPU runner
//!   `f::<N>` per row of `N / width` workgroups side by side, walking a run of workgroups
//!   ([`GroupSpan`](crate::executor::GroupSpan)) row by row (compiled for AVX2 too, chosen at run
//!   time), so the GPU keeps its workgroup shape whatever width suits the CPU.
//!   `lanes(N, avx512 M)` adds a runner compiled for AVX-512 that calls `f::<M>`, taken where
//!   the CPU has it (each width measured per kernel: AVX-512's 32 registers hold wider rows);
//! - `workgroup TYPE, phases [p1, p2, ..]`: phases separated by workgroup barriers, sharing
//!   workgroup memory of `TYPE`; each phase is `p(WorkgroupIds, &params, bindings.., &mut local)`.
//!   The CPU runs each phase over the whole workgroup before the next, as the barriers imply.
//!   A phase written `p lanes(L)` is `p::<L>` over [`crate::lanes`] on the CPU (one call per `L`
//!   invocations consecutive in x, `L` dividing the workgroup's width) and `p::<1>` on the GPU.

/// Declares every kernel once; see the [module docs](crate::declare). Invoked only by
/// `kernels::table`.
#[doc(hidden)]
#[macro_export]
macro_rules! kernel_table {
    // ---- one entry at a time: normalise, then number the bindings ----
    (@kernels [$($done:tt)*]) => { $crate::kernel_table!(@emit $($done)*); };
    (@kernels [$($done:tt)*]
        $(#[$doc:meta])*
        $entry:ident => $desc:ident, $binds:ident, $io:ident: fn $($kfn:ident)::+,
        threads($x:tt, $y:tt, $z:tt), params $params:ty
        { $($bn:ident: $ba:ident $bt:ty),* $(,)? }
        $($rest:tt)*
    ) => {
        $crate::kernel_table!(@bind [$($done)*]
            [[$(#[$doc])*] $entry $desc $binds $io [fn ($($kfn)::+)] ($x, $y, $z) [$params]]
            [] [] [] [0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23] [$($bn: $ba $bt,)*] $($rest)*);
    };
    (@kernels [$($done:tt)*]
        $(#[$doc:meta])*
        $entry:ident => $desc:ident, $binds:ident, $io:ident:
            lanes($lanes:tt $(, avx512 $wide:tt)?) $($kfn:ident)::+,
        threads($x:tt, $y:tt, $z:tt), params $params:ty
        { $($bn:ident: $ba:ident $bt:ty),* $(,)? }
        $($rest:tt)*
    ) => {
        $crate::kernel_table!(@bind [$($done)*]
            [[$(#[$doc])*] $entry $desc $binds $io [lanes $lanes [$($wide)?] ($($kfn)::+)]
                ($x, $y, $z) [$params]]
            [] [] [] [0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23] [$($bn: $ba $bt,)*] $($rest)*);
    };
    (@kernels [$($done:tt)*]
        $(#[$doc:meta])*
        $entry:ident => $desc:ident, $binds:ident, $io:ident: workgroup $wg:ty,
        phases [$($($phase:ident)::+ $(lanes($pl:tt))?),+], threads($x:tt, $y:tt, $z:tt),
        params $params:ty
        { $($bn:ident: $ba:ident $bt:ty),* $(,)? }
        $($rest:tt)*
    ) => {
        $crate::kernel_table!(@bind [$($done)*]
            [[$(#[$doc])*] $entry $desc $binds $io [phases [$wg] $(([$($pl)?] $($phase)::+))+]
                ($x, $y, $z) [$params]]
            [] [] [] [0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23] [$($bn: $ba $bt,)*] $($rest)*);
    };
    (@bind $done:tt $head:tt [$($z:tt)*] [$($f:tt)*] $t:tt [$n:tt $($ns:tt)*]
        [$bn:ident: read $bt:ty, $($more:tt)*]
        $($rest:tt)*) => {
        $crate::kernel_table!(@bind $done $head [$($z)* ($n $bn Read read [] buffer $bt)]
            [$($f)* ($bn [] $bt)] $t [$($ns)*]
            [$($more)*] $($rest)*);
    };
    (@bind $done:tt $head:tt [$($z:tt)*] [$($f:tt)*] $t:tt [$n:tt $($ns:tt)*]
        [$bn:ident: write $bt:ty, $($more:tt)*]
        $($rest:tt)*) => {
        $crate::kernel_table!(@bind $done $head [$($z)* ($n $bn Write write [mut] buffer $bt)]
            [$($f)* ($bn [mut] $bt)] $t
            [$($ns)*] [$($more)*] $($rest)*);
    };
    (@bind $done:tt $head:tt [$($z:tt)*] [$($f:tt)*] $t:tt [$n:tt $($ns:tt)*]
        [$bn:ident: update $bt:ty, $($more:tt)*]
        $($rest:tt)*) => {
        $crate::kernel_table!(@bind $done $head [$($z)* ($n $bn Update write [mut] buffer $bt)]
            [$($f)* ($bn [mut] $bt)] $t
            [$($ns)*] [$($more)*] $($rest)*);
    };
    (@bind $done:tt $head:tt [$($z:tt)*] [$($f:tt)*] $t:tt [$n:tt $($ns:tt)*]
        [$bn:ident: atomic $bt:ty, $($more:tt)*]
        $($rest:tt)*) => {
        $crate::kernel_table!(@bind $done $head [$($z)* ($n $bn Atomic write [mut] buffer $bt)]
            [$($f)* ($bn [mut] $bt)] $t
            [$($ns)*] [$($more)*] $($rest)*);
    };
    (@bind $done:tt $head:tt [$($z:tt)*] $f:tt [$($t:tt)*] [$n:tt $($ns:tt)*]
        [$bn:ident: sampled $bt:ty, $($more:tt)*]
        $($rest:tt)*) => {
        $crate::kernel_table!(@bind $done $head [$($z)* ($n $bn Sampled read [] texture $bt)] $f
            [$($t)* ($bn [])]
            [$($ns)*] [$($more)*] $($rest)*);
    };
    (@bind $done:tt $head:tt [$($z:tt)*] $f:tt [$($t:tt)*] [$n:tt $($ns:tt)*]
        [$bn:ident: storage $bt:ty, $($more:tt)*] $($rest:tt)*) => {
        $crate::kernel_table!(@bind $done $head [$($z)* ($n $bn Storage write [mut] texture $bt)] $f
            [$($t)* ($bn [mut])] [$($ns)*] [$($more)*] $($rest)*);
    };
    (@bind [$($done:tt)*] [$($head:tt)*] $z:tt $f:tt $t:tt $ns:tt [] $($rest:tt)*) => {
        $crate::kernel_table!(@kernels [$($done)* {$($head)* $z $f $t}] $($rest)*);
    };

    // ---- everything derived from the normalised entries ----
    (@emit $({
        [$($doc:tt)*] $entry:ident $desc:ident $binds:ident $io:ident [$($kind:tt)*]
        ($x:tt, $y:tt, $z:tt) [$params:ty]
        [$(($n:tt $bn:ident $acc:ident $method:ident [$($m:tt)?] $bk:ident $bt:ty))*]
        [$(($fname:ident [$($fm:tt)?] $ft:ty))*] [$(($tname:ident [$($tm:tt)?]))*]
    })*) => {
        $(
            #[doc = concat!("The storage buffers of `", stringify!($entry),
                "` as the kernel function sees them.")]
            pub struct $io<'a> {
                $(
                    #[doc = concat!("Binding `", stringify!($fname), "`.")]
                    pub $fname: &'a $($fm)? [$ft],
                )*
            }

            $($doc)*
            #[cfg(not(target_arch = "spirv"))]
            pub static $desc: $crate::executor::KernelDesc = $crate::executor::KernelDesc {
                entry: stringify!($entry),
                workgroup_size: [$x, $y, $z],
                bindings: &[$($crate::executor::Binding {
                    name: stringify!($bn),
                    ty: stringify!($bt),
                    elem_size: core::mem::size_of::<$bt>() as u32,
                    access: $crate::executor::Access::$acc,
                }),*],
                params_size: core::mem::size_of::<$params>() as u32,
                cpu: $crate::kernel_table!(@cpu [$($kind)*] ($x, $y, $z) $io [$params]
                    [$(($n $bn $method [$($m)?] $bk $bt))*] [$(($fname [$($fm)?]))*]
                    [$(($tname [$($tm)?]))*]),
            };

            #[doc = concat!("The buffers of one `", stringify!($entry), "` pass, by binding name.")]
            #[cfg(not(target_arch = "spirv"))]
            #[repr(C)]
            #[derive(Copy, Clone, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
            pub struct $binds {
                $(
                    #[doc = concat!("Binding ", stringify!($n), ": `", stringify!($bt), "` elements, ",
                        stringify!($acc), ".")]
                    pub $bn: $crate::executor::BufferId,
                )*
            }

            #[cfg(not(target_arch = "spirv"))]
            impl $binds {
                /// The kernel these bindings are for.
                pub const KERNEL: &'static $crate::executor::KernelDesc = &$desc;

                /// The buffers in binding order.
                pub fn buffers(&self) -> &[$crate::executor::BufferId] {
                    bytemuck::cast_slice(core::slice::from_ref(self))
                }

                /// A pass launching `groups` workgroups.
                pub fn pass<'a>(
                    &'a self,
                    params: &'a $params,
                    groups: $crate::executor::Groups,
                ) -> $crate::executor::Pass<'a> {
                    $crate::executor::Pass {
                        kernel: &$desc,
                        buffers: self.buffers(),
                        params: bytemuck::bytes_of(params),
                        groups,
                    }
                }

                /// A pass with one invocation per element of a `width × height × planes` grid.
                pub fn over_grid<'a>(
                    &'a self,
                    params: &'a $params,
                    width: u32,
                    height: u32,
                    planes: u32,
                ) -> $crate::executor::Pass<'a> {
                    $crate::executor::Pass::over_grid(
                        &$desc,
                        self.buffers(),
                        bytemuck::bytes_of(params),
                        width,
                        height,
                        planes,
                    )
                }
            }
        )*

        /// Every kernel, for backends that build all pipelines up front and for the tests.
        #[cfg(not(target_arch = "spirv"))]
        pub static ALL: &[&$crate::executor::KernelDesc] = &[$(&$desc),*];

        /// The `#[spirv(compute)]` entry point of every kernel, for the crate root of the shader
        /// crate (entry names are the function names only at the root).
        #[macro_export]
        macro_rules! spirv_entries {
            () => {
                #[allow(unused_imports)]
                use $crate::kernels::names::*;
                $(
                    $crate::kernel_table!(@entry [$($kind)*] $entry $io ($x, $y, $z) [$params]
                        [$(($n $bn [$($m)?] $bk $bt))*] [$($fname)*] [$(($tname [$($tm)?]))*]);
                )*
            };
        }
    };

    // ---- the native runner of a run of workgroups ----
    (@cpu [fn ($kfn:path)] $threads:tt $io:ident [$params:ty]
        [$(($n:tt $bn:ident $method:ident [$($m:tt)?] $bk:ident $bt:ty))*]
        [$(($fname:ident [$($fm:tt)?]))*] [$(($tname:ident [$($tm:tt)?]))*]) => {{
        unsafe fn run(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            let params: $params = b.params();
            // SAFETY: the executor laid the buffers out as declared (the caller's contract).
            $(let $bn = unsafe { b.$method::<$bt>($n) };)*
            for group in span.groups() {
                b.for_each_invocation(group, |id| {
                    $kfn(id, &params, $io { $($fname: &$($fm)? *$fname),* }
                        $(, $crate::textures::IntoTexture::into_texture(&$($tm)? *$tname))*);
                });
            }
        }
        run
    }};
    (@cpu [lanes $lanes:tt [$($wide:tt)?] ($($kfn:ident)::+)] ($x:tt, $y:tt, $z:tt) $io:ident
        [$params:ty] [$(($n:tt $bn:ident $method:ident [$($m:tt)?] $bk:ident $bt:ty))*]
        [$(($fname:ident [$($fm:tt)?]))*] [$(($tname:ident [$($tm:tt)?]))*]) => {{
        #[inline(always)]
        unsafe fn lanes<const L: usize>(
            span: $crate::executor::GroupSpan,
            b: &$crate::executor::CpuBindings<'_>,
        ) {
            // Each call covers `L` pixels of a row, `L / width` workgroups side by side; the
            // run's rows are walked one after another across the whole run (`GroupSpan`).
            // Pixels past the image's right edge are the kernel's to mask, as on the GPU. Plain
            // loops, no closure: the kernel must inline into `lanes_avx2`/`lanes_avx512` to get
            // their instructions.
            const {
                assert!(
                    L % $x == 0 && $crate::executor::GroupSpan::ALIGN as usize % (L / $x) == 0,
                    "lanes a multiple of the workgroup width that divides a run's alignment"
                )
            };
            let params: $params = b.params();
            // SAFETY: the executor laid the buffers out as declared (the caller's contract).
            $(let $bn = unsafe { b.$method::<$bt>($n) };)*
            let (x_start, x_end) = (span.x_start * $x, span.x_end * $x);
            for z in 0..$z {
                for y in 0..$y {
                    let mut x = x_start;
                    while x < x_end {
                        let id = $crate::glam::UVec3::new(x, span.y * $y + y, span.z * $z + z);
                        $($kfn)::+::<L>(id, &params, $io { $($fname: &$($fm)? *$fname),* }
                            $(, $crate::textures::IntoTexture::into_texture(&$($tm)? *$tname))*);
                        x += L as u32;
                    }
                }
            }
        }
        // The same code compiled for AVX2 (8 lanes in one register), F16C and FMA
        // (`math::mul_add`), chosen at run time.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        #[target_feature(enable = "avx2,f16c,fma")]
        unsafe fn lanes_avx2(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            // SAFETY: as `lanes`.
            unsafe { lanes::<$lanes>(span, b) }
        }
        $crate::kernel_table!(@avx512 [$($wide)?]);
        unsafe fn run(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            {
                let limit = $crate::executor::cpu_lanes();
                $crate::kernel_table!(@run_avx512 [$($wide)?] span b limit);
                $crate::kernel_table!(@run_avx2 span b limit);
            }
            // SAFETY: the caller's contract.
            unsafe { lanes::<$lanes>(span, b) }
        }
        run
    }};
    // A kernel declared `avx512 M` also gets a runner compiled for AVX-512 (16 lanes and 32
    // registers: wide rows spill less), `M` pixels per call, taken where the CPU has it.
    (@avx512 []) => {};
    (@avx512 [$wide:tt]) => {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        #[target_feature(enable = "avx2,fma,avx512f,avx512bw,avx512dq,avx512vl")]
        unsafe fn lanes_avx512(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            // SAFETY: as `lanes`.
            unsafe { lanes::<$wide>(span, b) }
        }
    };
    (@run_avx2 $span:ident $b:ident $limit:ident) => {
        if $limit >= $crate::executor::CpuLanes::Avx2
            && std::is_x86_feature_detected!("avx2")
            && std::is_x86_feature_detected!("f16c")
            && std::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has AVX2, F16C and FMA; the rest is the caller's contract.
            return unsafe { lanes_avx2($span, $b) };
        }
    };
    (@run_avx512 [] $span:ident $b:ident $limit:ident) => {};
    (@run_avx512 [$wide:tt] $span:ident $b:ident $limit:ident) => {
        if $limit >= $crate::executor::CpuLanes::Avx512
            && std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("fma")
            && std::is_x86_feature_detected!("avx512bw")
            && std::is_x86_feature_detected!("avx512dq")
            && std::is_x86_feature_detected!("avx512vl")
        {
            // SAFETY: the CPU has AVX-512 and FMA; the rest is the caller's contract.
            return unsafe { lanes_avx512($span, $b) };
        }
    };
    (@cpu [phases [$wg:ty] $($phase:tt)+] $threads:tt $io:ident [$params:ty]
        [$(($n:tt $bn:ident $method:ident [$($m:tt)?] $bk:ident $bt:ty))*]
        [$(($fname:ident [$($fm:tt)?]))*] []) => {{
        #[inline(always)]
        unsafe fn phases(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            let params: $params = b.params();
            // SAFETY: the executor laid the buffers out as declared (the caller's contract).
            $(let $bn = unsafe { b.$method::<$bt>($n) };)*
            for group in span.groups() {
                let mut local: $wg = bytemuck::Zeroable::zeroed();
                $crate::kernel_table!(@cpu_phases group $threads params local
                    [$io { $($bn: &$($m)? *$bn),* }] $($phase)+);
            }
        }
        $crate::kernel_table!(@phases_runner [] $($phase)+)
    }};
    // A kernel with a `lanes` phase also gets runners compiled for AVX2 and for AVX-512, as
    // `lanes` kernels do, taken where the CPU has them; one without runs as compiled.
    (@phases_runner [$($l:tt)*]) => {
        $crate::kernel_table!(@phases_run [$($l)*])
    };
    (@phases_runner [$($l:tt)*] ([$($pl:tt)?] $($phase:ident)::+) $($rest:tt)*) => {
        $crate::kernel_table!(@phases_runner [$($l)* $($pl)?] $($rest)*)
    };
    (@phases_run []) => {{
        unsafe fn run(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            // SAFETY: the caller's contract.
            unsafe { phases(span, b) }
        }
        run
    }};
    (@phases_run [$($l:tt)+]) => {{
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        #[target_feature(enable = "avx2,fma,avx512f,avx512bw,avx512dq,avx512vl")]
        unsafe fn lanes_avx512(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            // SAFETY: as `phases`.
            unsafe { phases(span, b) }
        }
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        #[target_feature(enable = "avx2,f16c,fma")]
        unsafe fn lanes_avx2(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            // SAFETY: as `phases`.
            unsafe { phases(span, b) }
        }
        unsafe fn run(span: $crate::executor::GroupSpan, b: &$crate::executor::CpuBindings<'_>) {
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            {
                let limit = $crate::executor::cpu_lanes();
                $crate::kernel_table!(@run_avx512 [x] span b limit);
                $crate::kernel_table!(@run_avx2 span b limit);
            }
            // SAFETY: the caller's contract.
            unsafe { phases(span, b) }
        }
        run
    }};

    (@cpu_phases $group:ident $threads:tt $p:ident $local:ident [$($io:tt)*]) => {};
    // Plain loops, no closure: a closure would not inherit the AVX-512 runner's target features
    // and would be called, not inlined, from it. A `lanes(L)` phase is one call per `L`
    // invocations consecutive in x (`crate::lanes`).
    (@cpu_phases $group:ident ($x:tt, $y:tt, $z:tt) $p:ident $local:ident [$($io:tt)*]
        ([$($pl:tt)?] $($phase:ident)::+) $($rest:tt)*) => {
        let step: u32 = $crate::kernel_table!(@phase_step [$($pl)?] $x);
        let base = $group * $crate::glam::UVec3::new($x, $y, $z);
        for z in 0..$z {
            for y in 0..$y {
                let mut x = 0;
                while x < $x {
                    let ids = $crate::kernels::WorkgroupIds {
                        global: base + $crate::glam::UVec3::new(x, y, z),
                        group: $group,
                        local_index: (z * $y + y) * $x + x,
                    };
                    $($phase)::+$(::<$pl>)?(ids, &$p, $($io)*, &mut $local);
                    x += step;
                }
            }
        }
        $crate::kernel_table!(@cpu_phases $group ($x, $y, $z) $p $local [$($io)*] $($rest)*);
    };
    (@phase_step [] $x:tt) => { 1 };
    (@phase_step [$pl:tt] $x:tt) => {{
        const { assert!($pl > 0 && $x % $pl == 0, "a phase's lanes divide the workgroup's width") };
        $pl
    }};

    // ---- the SPIR-V entry point ----
    (@entry [fn ($kfn:path)] $entry:ident $io:ident ($x:tt, $y:tt, $z:tt) [$params:ty]
        [$(($n:tt $bn:ident [$($m:tt)?] $bk:ident $bt:ty))*] $f:tt $t:tt) => {
        $crate::kernel_table!(@fn_params [($kfn), $entry, $io, ($x, $y, $z), $params, $f, $t] []
            $(($n $bn [$($m)?] $bk $bt))*);
    };
    // The parameters of a `fn` or `lanes` kernel's entry (`lanes` calls `f::<1>`), one binding
    // at a time: a storage buffer, or a sampled image for a `sampled` binding
    // (`crate::textures::Fetch`).
    (@fn_params $head:tt [$($done:tt)*] ($n:tt $bn:ident [$($m:tt)?] buffer $bt:ty) $($rest:tt)*) => {
        $crate::kernel_table!(@fn_params $head [$($done)*
            #[spirv(storage_buffer, descriptor_set = 0, binding = $n)] $bn: &$($m)? [$bt],]
            $($rest)*);
    };
    (@fn_params $head:tt [$($done:tt)*] ($n:tt $bn:ident [] texture $bt:ty) $($rest:tt)*) => {
        $crate::kernel_table!(@fn_params $head [$($done)*
            #[spirv(descriptor_set = 0, binding = $n)] $bn: &$crate::textures::SampledImage,]
            $($rest)*);
    };
    (@fn_params $head:tt [$($done:tt)*] ($n:tt $bn:ident [mut] texture $bt:ty) $($rest:tt)*) => {
        $crate::kernel_table!(@fn_params $head [$($done)*
            #[spirv(descriptor_set = 0, binding = $n)] $bn: &$crate::textures::StorageImage,]
            $($rest)*);
    };
    (@fn_params [$callee:tt, $entry:ident, $io:ident, ($x:tt, $y:tt, $z:tt), $params:ty,
        [$($fname:ident)*], [$(($tname:ident [$($tm:tt)?]))*]] [$($done:tt)*]) => {
        // One parameter per descriptor binding: the entry point's interface, not a design choice.
        #[allow(clippy::too_many_arguments)]
        #[spirv(compute(threads($x, $y, $z)))]
        pub fn $entry(
            #[spirv(global_invocation_id)] id: $crate::glam::UVec3,
            #[spirv(push_constant)] params: &$params,
            $($done)*
        ) {
            $callee(id, params, $crate::kernels::$io { $($fname),* } $(, $tname)*);
        }
    };
    (@entry [lanes $lanes:tt $wide:tt ($($kfn:ident)::+)] $entry:ident $io:ident ($x:tt, $y:tt, $z:tt)
        [$params:ty] [$(($n:tt $bn:ident [$($m:tt)?] $bk:ident $bt:ty))*] $f:tt $t:tt) => {
        $crate::kernel_table!(@fn_params [($($kfn)::+::<1>), $entry, $io, ($x, $y, $z), $params, $f, $t]
            [] $(($n $bn [$($m)?] $bk $bt))*);
    };
    (@entry [phases [$wg:ty] $($phase:tt)+] $entry:ident $io:ident ($x:tt, $y:tt, $z:tt)
        [$params:ty] [$(($n:tt $bn:ident [$($m:tt)?] $bk:ident $bt:ty))*] $f:tt []) => {
        #[spirv(compute(threads($x, $y, $z)))]
        pub fn $entry(
            #[spirv(global_invocation_id)] id: $crate::glam::UVec3,
            #[spirv(workgroup_id)] group: $crate::glam::UVec3,
            #[spirv(local_invocation_index)] local_index: u32,
            #[spirv(push_constant)] params: &$params,
            $(#[spirv(storage_buffer, descriptor_set = 0, binding = $n)] $bn: &$($m)? [$bt],)*
            #[spirv(workgroup)] local: &mut $wg,
        ) {
            let ids = $crate::kernels::WorkgroupIds {
                global: id,
                group,
                local_index,
            };
            $crate::kernel_table!(@phases ids params
                [$crate::kernels::$io { $($bn: &$($m)? *$bn),* }] local $($phase)+);
        }
    };
    (@phases $ids:ident $p:ident [$($io:tt)*] $local:ident $first:tt $($rest:tt)*) => {
        $crate::kernel_table!(@call_phase $ids $p [$($io)*] $local $first);
        $crate::kernel_table!(@barrier_phases $ids $p [$($io)*] $local $($rest)*);
    };
    (@barrier_phases $ids:ident $p:ident [$($io:tt)*] $local:ident) => {};
    (@barrier_phases $ids:ident $p:ident [$($io:tt)*] $local:ident $phase:tt $($rest:tt)*) => {
        $crate::atomic::workgroup_barrier();
        $crate::kernel_table!(@call_phase $ids $p [$($io)*] $local $phase);
        $crate::kernel_table!(@barrier_phases $ids $p [$($io)*] $local $($rest)*);
    };
    // One invocation's call of a phase; a `lanes` phase runs one lane on the GPU.
    (@call_phase $ids:ident $p:ident [$($io:tt)*] $local:ident ([] $($phase:ident)::+)) => {
        $($phase)::+($ids, $p, $($io)*, $local);
    };
    (@call_phase $ids:ident $p:ident [$($io:tt)*] $local:ident ([$pl:tt] $($phase:ident)::+)) => {
        $($phase)::+::<1>($ids, $p, $($io)*, $local);
    };

    // ---- the table itself ----
    ($($table:tt)*) => { $crate::kernel_table!(@kernels [] $($table)*); };
}
