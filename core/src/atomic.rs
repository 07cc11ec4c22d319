//! Integer atomics, the one place kernels may contend (counters, histograms, packed-key min/max).
//!
//! On SPIR-V these are `OpAtomic*` with queue-family scope for storage buffers (device scope needs
//! `VulkanMemoryModelDeviceScope`, which naga rejects) and workgroup scope for workgroup memory.
//! On the CPU backend, workgroups run in parallel on threads that share the buffers like GPU
//! invocations do, so the same calls are real `AtomicU32` operations there. Relaxed ordering is
//! enough: results are only read after the dispatch completes.

#[cfg(not(target_arch = "spirv"))]
use core::sync::atomic::{AtomicU32, Ordering};

#[cfg(target_arch = "spirv")]
use spirv_std::memory::{Scope, Semantics};

#[cfg(not(target_arch = "spirv"))]
#[inline]
fn cpu_atomic(target: &mut u32) -> &AtomicU32 {
    // SAFETY: `u32` and `AtomicU32` have the same size and alignment; the pointer comes from a
    // live `&mut u32`.
    unsafe { AtomicU32::from_ptr(target) }
}

macro_rules! atomic_fn {
    ($(#[$doc:meta])* $name:ident, $spirv:ident, $cpu:ident, $scope:ident) => {
        $(#[$doc])*
        #[inline]
        pub fn $name(target: &mut u32, value: u32) -> u32 {
            #[cfg(target_arch = "spirv")]
            // SAFETY: `target` is a valid storage or workgroup location.
            unsafe {
                spirv_std::arch::$spirv::<u32, { Scope::$scope as u32 }, { Semantics::NONE.bits() }>(
                    target, value,
                )
            }
            #[cfg(not(target_arch = "spirv"))]
            {
                cpu_atomic(target).$cpu(value, Ordering::Relaxed)
            }
        }
    };
}

atomic_fn!(
    /// Atomic add on a storage buffer element; returns the previous value.
    add, atomic_i_add, fetch_add, QueueFamily
);
atomic_fn!(
    /// Atomic unsigned min on a storage buffer element; returns the previous value.
    min, atomic_u_min, fetch_min, QueueFamily
);
atomic_fn!(
    /// Atomic unsigned max on a storage buffer element; returns the previous value.
    max, atomic_u_max, fetch_max, QueueFamily
);
/// Atomic add on workgroup memory; returns the previous value. On the CPU backend one thread
/// runs a workgroup's invocations one after another (`kernels::WorkgroupIds`), so its memory has
/// no other writer and a plain add does: a locked one per pixel was most of a histogram's time.
#[inline]
pub fn add_workgroup(target: &mut u32, value: u32) -> u32 {
    #[cfg(target_arch = "spirv")]
    // SAFETY: `target` is a valid workgroup location.
    unsafe {
        spirv_std::arch::atomic_i_add::<u32, { Scope::Workgroup as u32 }, { Semantics::NONE.bits() }>(
            target, value,
        )
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        let old = *target;
        *target = old.wrapping_add(value);
        old
    }
}

/// Waits until every invocation of the workgroup reaches it, and makes workgroup memory writes
/// visible. On the CPU backend the phases of a workgroup run one after another, so this is a no-op
/// there: kernels that use it are split into phase functions (see `kernels::buckets`).
#[inline]
pub fn workgroup_barrier() {
    #[cfg(target_arch = "spirv")]
    spirv_std::arch::workgroup_memory_barrier_with_group_sync();
}
