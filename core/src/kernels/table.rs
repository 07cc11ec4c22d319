//! The declaration of every kernel: the one place, besides its function and its equivalence case,
//! where a kernel is written. See [`crate::declare`] for what is derived from each entry.
//!
//! An entry reads `entry => DESC, Bindings, Io: fn module::function, threads(x, y, z), params Type
//! { name: read|write|update|atomic|sampled|storage ElementType, .. }`. Bindings are numbered in
//! order; `write` means each invocation writes only elements it owns (without reading them),
//! `update` that it reads and rewrites only elements it owns (in place), `atomic` that invocations
//! contend through `crate::atomic`; `sampled` is an engine texture read by texel fetches and
//! `storage` one written (element type `Texel`; `fn` and `lanes` kernels take each as an
//! `impl Fetch` or `impl Store` argument after their buffers, `crate::textures`). Types are written
//! `module::Type`, or bare when [`super::names`] lists them.

use super::names::*;

crate::kernel_table! {
    /// [`accumulate::accumulate`]: temporal accumulation of the new samples into the reprojected
    /// history, in place (each invocation reads and writes its own element); `changes` is
    /// [`detect::detect`]'s `λ`; `counters` has `payload::COUNTERS_LEN` words.
    accumulate => ACCUMULATE, AccumulateBindings, AccumulateIo: lanes(16, avx512 64) accumulate::accumulate,
    threads(8, 8, 1), params accumulate::AccumulateParams {
        history: update PackedPayload,
        samples: read PackedSample,
        changes: read f32,
        counters: atomic u32,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
    }

    /// [`detect::detect`]: the change detector, between raygen and accumulation (it reads the
    /// neighbours' history, which accumulation then overwrites in place).
    detect => DETECT, DetectBindings, DetectIo: lanes(16, avx512 32) detect::detect,
    threads(8, 8, 1), params detect::DetectParams {
        history: read PackedPayload,
        samples: read PackedSample,
        changes: write f32,
    }

    /// [`atrous::atrous`]: one à-trous iteration; `tiles` holds the iterations each tile needs,
    /// `guide` the hit-distance guide of plane `guide_plane` (one element when none).
    atrous => ATROUS, AtrousBindings, AtrousIo: lanes(32, avx512 64) atrous::atrous,
    threads(8, 8, 1), params atrous::AtrousParams {
        input: read PackedFiltered,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        view: read View,
        tiles: read TileWord,
        guide: read f32,
        penumbra: read f32,
        out: write PackedFiltered,
    }

    /// [`atrous::tile`]: [`atrous::atrous`] with its taps from a workgroup tile of texels
    /// decoded once ([`atrous::tile::load`], [`atrous::tile::filter`]); dispatched over
    /// [`atrous::tile::grid`].
    atrous_tiled => ATROUS_TILED, AtrousTiledBindings, AtrousTiledIo: workgroup atrous::tile::Tile,
    phases [atrous::tile::load, atrous::tile::filter],
    threads(8, 8, 1), params atrous::AtrousParams {
        input: read PackedFiltered,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        view: read View,
        tiles: read TileWord,
        guide: read f32,
        penumbra: read f32,
        out: write PackedFiltered,
    }

    /// [`atrous::pair`]: the first two à-trous iterations (steps 1 and 2) in one dispatch, the
    /// first's results kept in workgroup memory ([`atrous::pair::load`], [`atrous::pair::first`],
    /// [`atrous::pair::second`]); `params` are the first's.
    atrous_pair => ATROUS_PAIR, AtrousPairBindings, AtrousPairIo: workgroup atrous::pair::Pair,
    phases [atrous::pair::load, atrous::pair::first, atrous::pair::second],
    threads(8, 8, 1), params atrous::AtrousParams {
        input: read PackedFiltered,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        view: read View,
        tiles: read TileWord,
        guide: read f32,
        penumbra: read f32,
        out: write PackedFiltered,
    }

    /// [`atrous::atrous_engine`]: the last à-trous iteration, into the engine's texture.
    atrous_engine => ATROUS_ENGINE, AtrousEngineBindings, AtrousEngineIo: lanes(32, avx512 64) atrous::atrous_engine,
    threads(8, 8, 1), params atrous::AtrousParams {
        input: read PackedFiltered,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        view: read View,
        tiles: read TileWord,
        guide: read f32,
        penumbra: read f32,
        out: storage Texel,
    }

    /// [`classify::classify`]: iterations per 8×8 tile from the words `variance` gathered, and
    /// their histogram; one invocation per tile.
    classify => CLASSIFY, ClassifyBindings, ClassifyIo: fn classify::classify,
    threads(8, 8, 1), params classify::ClassifyParams {
        tiles: update TileWord,
        histogram: atomic u32,
    }

    /// The bucket histogram of each plane group's ray requests ([`buckets::clear`],
    /// [`buckets::count`], [`buckets::flush`]; z = group); `counts` has `buckets::COUNTS_LEN`
    /// words per group, added to (fill it first).
    count_buckets => COUNT_BUCKETS, CountBucketsBindings, CountBucketsIo: workgroup [u32; buckets::BUCKET_COUNT as usize],
    phases [buckets::clear, buckets::count, buckets::flush],
    threads(16, 16, 1), params buckets::BucketParams {
        requests: read Request,
        counts: atomic u32,
    }

    /// [`gbuffer::gbuffer`]: the built-in renderer's primary rays: the engine inputs (depth, normal +
    /// roughness, motion) and the renderer's own `geometry` (geometric normal, instance).
    gbuffer => GBUFFER, GbufferBindings, GbufferIo: fn gbuffer::gbuffer,
    threads(8, 8, 1), params gbuffer::GbufferParams {
        nodes: read BvhNode,
        tris: read Triangle,
        normals: read TriangleNormals,
        instances: read InstanceData,
        depth: write Depth,
        normal_roughness: write NormalRoughness,
        motion: write Motion,
        geometry: write Geometry,
    }

    /// [`ingest::ingest`]: the engine's G-buffer textures (`crate::textures::Texture`), in its
    /// conventions, decoded into this frame's depth, normal + roughness and motion.
    ingest => INGEST, IngestBindings, IngestIo: fn ingest::ingest,
    threads(8, 8, 1), params inputs::IngestParams {
        engine_depth: sampled Texel,
        engine_normal: sampled Texel,
        engine_motion: sampled Texel,
        view: read View,
        depth: write Depth,
        normal_roughness: write NormalRoughness,
        motion: write Motion,
    }

    /// [`raygen::raygen_ao`]: AO rays of the compacted work list; dispatch indirectly from `args`
    /// at byte offset 4.
    raygen_ao => RAYGEN_AO, RaygenAoBindings, RaygenAoIo: fn raygen::raygen_ao,
    threads(64, 1, 1), params raygen::AoParams {
        work: read WorkEntry,
        args: read u32,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        geometry: read Geometry,
        view: read View,
        history: read PackedPayload,
        nodes: read BvhNode,
        tris: read Triangle,
        out: write PackedSample,
    }

    /// [`raygen::raygen_shadow`]: shadow rays toward each area light; dispatch as `raygen_ao`.
    raygen_shadow => RAYGEN_SHADOW, RaygenShadowBindings, RaygenShadowIo: fn raygen::raygen_shadow,
    threads(64, 1, 1), params raygen::ShadowParams {
        work: read WorkEntry,
        args: read u32,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        geometry: read Geometry,
        view: read View,
        history: read PackedPayload,
        nodes: read BvhNode,
        tris: read Triangle,
        lights: read AreaLight,
        out: write PackedSample,
        blockers: write f32,
    }

    /// [`reproject::reproject`]: history reprojection and ray-rate requests; one invocation per
    /// pixel (planes are looped inside).
    reproject => REPROJECT, ReprojectBindings, ReprojectIo: lanes(16, avx512 64) reproject::reproject,
    threads(8, 8, 1), params reproject::ReprojectParams {
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        motion: read Motion,
        prev_depth: read Depth,
        prev_normal_roughness: read NormalRoughness,
        view: read View,
        history: read PackedPayload,
        mask: read VrsMask,
        gradient: read GradientSample,
        importance: read f32,
        parallax: read [f32; 2],
        out: write PackedPayload,
        requests: write Request,
    }

    /// [`reproject::reproject_engine`]: [`reproject::reproject`] reading this frame's inputs from
    /// the engine's textures in its conventions (`conventions`: one element) and writing them,
    /// decoded, to the denoiser's input buffers.
    reproject_engine => REPROJECT_ENGINE, ReprojectEngineBindings, ReprojectEngineIo: lanes(16, avx512 64) reproject::reproject_engine,
    threads(8, 8, 1), params reproject::ReprojectParams {
        engine_depth: sampled Texel,
        engine_normal: sampled Texel,
        engine_motion: sampled Texel,
        conventions: read IngestParams,
        depth: write Depth,
        normal_roughness: write NormalRoughness,
        motion: write Motion,
        prev_depth: read Depth,
        prev_normal_roughness: read NormalRoughness,
        view: read View,
        history: read PackedPayload,
        mask: read VrsMask,
        gradient: read GradientSample,
        importance: read f32,
        parallax: read [f32; 2],
        out: write PackedPayload,
        requests: write Request,
    }

    /// [`variance::variance`]: temporal variance, or the spatial estimate for young history; folds
    /// each tile's worst variance into `tiles` (zeroed before) for `classify`.
    variance => VARIANCE, VarianceBindings, VarianceIo: lanes(16, avx512 64) variance::variance,
    threads(8, 8, 1), params variance::VarianceParams {
        payload: read PackedPayload,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        view: read View,
        guide: read f32,
        out: write PackedFiltered,
        tiles: atomic TileWord,
    }

    /// The load balancer ([`balance::setup`], [`balance::sums`], [`balance::pick`],
    /// [`balance::rings`], [`balance::write`]: [`balance::solve`] with its sums spread over one
    /// workgroup); `counts` from `count_buckets`; `refill` holds last frame's refill lists'
    /// arguments, from whose counts rays are set aside for this frame's lists
    /// ([`balance::refill_reserve`]), and is reset with `args`; one workgroup.
    balance => BALANCE, BalanceBindings, BalanceIo: workgroup balance::Shared,
    phases [balance::setup, balance::sums, balance::pick, balance::rings, balance::write],
    threads(128, 1, 1), params balance::BalanceParams {
        counts: read u32,
        out: write Balance,
        args: write u32,
        refill: update u32,
    }

    /// The histogram of the priorities of every tracing pixel's last ray, and the rays, per
    /// plane group (z) ([`trim::clear`], [`trim::count`], [`trim::flush`]); `hist` has
    /// `trim::HIST_LEN` words per group, added to (fill it first).
    trim_count => TRIM_COUNT, TrimCountBindings, TrimCountIo: workgroup trim::Local,
    phases [trim::clear, trim::count lanes(16), trim::flush],
    threads(16, 16, 1), params trim::TrimParams {
        requests: read Request,
        decision: read Balance,
        noise: read f32,
        hist: atomic u32,
    }

    /// [`trim::cut`]: each plane group's cut from its histogram, into its decision; one
    /// invocation per group.
    trim_cut => TRIM_CUT, TrimCutBindings, TrimCutIo: fn trim::cut,
    threads(64, 1, 1), params trim::CutParams {
        hist: read u32,
        decision: update Balance,
    }

    /// [`apply::apply`]: rays per pixel, rng offsets and the compacted work list.
    apply => APPLY, ApplyBindings, ApplyIo: lanes(16, avx512 64) apply::apply,
    threads(8, 8, 1), params apply::ApplyParams {
        requests: read Request,
        decision: read Balance,
        noise: read f32,
        work: write WorkEntry,
        args: atomic u32,
        samples: write PackedSample,
    }

    /// [`refill::refill`]: a reset frame's second work list per plane group (the shadows' mixed
    /// windows, before [`refill::cap`], the second raygen and accumulation).
    refill => REFILL, RefillBindings, RefillIo: lanes(16, avx512 64) refill::refill,
    threads(8, 8, 1), params refill::RefillParams {
        requests: read Request,
        samples: read PackedSample,
        work: write WorkEntry,
        args: atomic u32,
        hist: atomic u32,
    }

    /// [`refill::detect_refill`]: the change detector and the refill lists in one pass (each
    /// plane group's `λ` tested where it is computed), outside reset frames.
    detect_refill => DETECT_REFILL, DetectRefillBindings, DetectRefillIo: lanes(16, avx512 32) refill::detect_refill,
    threads(8, 8, 1), params refill::DetectRefillParams {
        requests: read Request,
        samples: read PackedSample,
        history: read PackedPayload,
        changes: write f32,
        work: write WorkEntry,
        args: atomic u32,
        hist: atomic u32,
    }

    /// [`refill::tile`]: [`refill::detect_refill`] with the detector's terms from a workgroup
    /// tile ([`refill::tile::load`], [`refill::tile::finish`]).
    detect_refill_tiled => DETECT_REFILL_TILED, DetectRefillTiledBindings, DetectRefillTiledIo: workgroup refill::tile::Tile,
    phases [refill::tile::load, refill::tile::finish],
    threads(8, 8, 1), params refill::DetectRefillParams {
        requests: read Request,
        samples: read PackedSample,
        history: read PackedPayload,
        changes: write f32,
        work: write WorkEntry,
        args: atomic u32,
        hist: atomic u32,
    }

    /// [`fill::fill`]: writes a value to the first `len` words; `len.div_ceil(64)` groups.
    fill => FILL, FillBindings, FillIo: fn fill::fill,
    threads(64, 1, 1), params fill::FillParams {
        buf: write u32,
    }

    /// [`copy::copy`]: `dst[i] = src[i]` over a `row × rows` grid; the bandwidth yardstick.
    copy => COPY, CopyBindings, CopyIo: fn copy::copy,
    threads(64, 1, 1), params copy::CopyParams {
        src: read u32,
        dst: write u32,
    }

    /// [`gradient::project`]: forward projection of one previous sample per stratum.
    gradient_project => GRADIENT_PROJECT, GradientProjectBindings, GradientProjectIo: fn gradient::project,
    threads(8, 8, 1), params gradient::ProjectParams {
        prev_depth: read Depth,
        prev_normal_roughness: read NormalRoughness,
        prev_geometry: read Geometry,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        geometry: read Geometry,
        view: read View,
        prev_samples: read PackedSample,
        next: read InstanceData,
        keys: atomic GradientKey,
    }

    /// [`gradient::retrace_ao`]: re-trace of the projected AO samples; one invocation per cell.
    gradient_ao => GRADIENT_AO, GradientAoBindings, GradientAoIo: fn gradient::retrace_ao,
    threads(8, 8, 1), params gradient::RetraceParams {
        keys: read GradientKey,
        prev_depth: read Depth,
        prev_normal_roughness: read NormalRoughness,
        prev_geometry: read Geometry,
        view: read View,
        next: read InstanceData,
        prev_payload: read PackedPayload,
        prev_samples: read PackedSample,
        nodes: read BvhNode,
        tris: read Triangle,
        out: write GradientSample,
    }

    /// [`gradient::retrace_shadow`]: as `gradient_ao`, toward the lights.
    gradient_shadow => GRADIENT_SHADOW, GradientShadowBindings, GradientShadowIo: fn gradient::retrace_shadow,
    threads(8, 8, 1), params gradient::RetraceParams {
        keys: read GradientKey,
        prev_depth: read Depth,
        prev_normal_roughness: read NormalRoughness,
        prev_geometry: read Geometry,
        view: read View,
        next: read InstanceData,
        prev_payload: read PackedPayload,
        prev_samples: read PackedSample,
        nodes: read BvhNode,
        tris: read Triangle,
        lights: read AreaLight,
        out: write GradientSample,
    }

    /// [`gradient::atrous`]: one iteration of the gradient reconstruction; cells × planes.
    gradient_atrous => GRADIENT_ATROUS, GradientAtrousBindings, GradientAtrousIo: fn gradient::atrous,
    threads(8, 8, 1), params gradient::GradientAtrousParams {
        input: read GradientSample,
        out: write GradientSample,
    }

    /// [`reflect::raygen_reflect`]: GGX reflection rays with direct light at the hits; dispatch
    /// as `raygen_ao`.
    raygen_reflect => RAYGEN_REFLECT, RaygenReflectBindings, RaygenReflectIo: fn reflect::raygen_reflect,
    threads(64, 1, 1), params reflect::RaygenParams {
        work: read WorkEntry,
        args: read u32,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        geometry: read Geometry,
        view: read View,
        history: read PackedPayload,
        nodes: read BvhNode,
        tris: read Triangle,
        lights: read AreaLight,
        out: update PackedSample,
        hits: update RayHit,
    }

    /// [`reflect::reflect_tiles`]: reflection importance per tile of `reflect::tile_grid`.
    reflect_tiles => REFLECT_TILES, ReflectTilesBindings, ReflectTilesIo: fn reflect::reflect_tiles,
    threads(8, 8, 1), params reflect::TileParams {
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        geometry: read Geometry,
        view: read View,
        nodes: read BvhNode,
        tris: read Triangle,
        lights: read AreaLight,
        importance: write f32,
    }

    /// [`reflect::reflect_motion`]: parallax motion of the reflected image.
    reflect_motion => REFLECT_MOTION, ReflectMotionBindings, ReflectMotionIo: fn reflect::reflect_motion,
    threads(8, 8, 1), params reflect::MotionParams {
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        motion: read Motion,
        view: read View,
        hits: read RayHit,
        parallax: write [f32; 2],
    }

    /// [`reflect::reflect_reuse`]: ray reuse between neighbours (rewrites plane `plane` of
    /// `samples`).
    reflect_reuse => REFLECT_REUSE, ReflectReuseBindings, ReflectReuseIo: fn reflect::reflect_reuse,
    threads(8, 8, 1), params reflect::ReuseParams {
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        geometry: read Geometry,
        view: read View,
        hits: read RayHit,
        samples: update PackedSample,
    }

    /// [`reflect::reflect_guide`]: the hit-distance guide of the à-trous reflection plane.
    reflect_guide => REFLECT_GUIDE, ReflectGuideBindings, ReflectGuideIo: fn reflect::reflect_guide,
    threads(8, 8, 1), params reflect::GuideParams {
        hits: read RayHit,
        guide: write f32,
    }

    /// [`ao_guide::march`]: the AO guide's unblocked fraction per pixel, before its blur.
    ao_guide_march => AO_GUIDE_MARCH, AoGuideMarchBindings, AoGuideMarchIo: lanes(32, avx512 64) ao_guide::march,
    threads(8, 8, 1), params ao_guide::MarchParams {
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        motion: read Motion,
        prev_depth: read Depth,
        prev_normal_roughness: read NormalRoughness,
        view: read View,
        prev_raw: read u32,
        raw: write u32,
    }

    /// [`ao_guide::blur`]: the AO guide, `raw`'s 4×4 mean on the pixel's surface; one invocation
    /// per two pixels of a row, binary16 each (`ao_guide::guide_at`).
    ao_guide_blur => AO_GUIDE_BLUR, AoGuideBlurBindings, AoGuideBlurIo: lanes(16, avx512 32) ao_guide::blur,
    threads(8, 8, 1), params ao_guide::GuideParams {
        raw: read u32,
        depth: read Depth,
        normal_roughness: read NormalRoughness,
        guide: write u32,
    }

    /// [`ao_guide::demodulate`]: the history divided by the AO guide on the AO planes, for the
    /// variance pass; one invocation per pixel and plane.
    ao_demodulate => AO_DEMODULATE, AoDemodulateBindings, AoDemodulateIo: lanes(16, avx512 32) ao_guide::demodulate,
    threads(8, 8, 1), params ao_guide::GuideParams {
        history: read PackedPayload,
        guide: read u32,
        out: write PackedPayload,
    }

    /// [`ao_guide::remodulate`]: the filter's output multiplied back by the AO guide, in place.
    ao_remodulate => AO_REMODULATE, AoRemodulateBindings, AoRemodulateIo: lanes(16, avx512 32) ao_guide::remodulate,
    threads(8, 8, 1), params ao_guide::GuideParams {
        guide: read u32,
        out: update PackedFiltered,
    }

    /// [`ao_guide::remodulate_into`]: [`ao_guide::remodulate`] into the engine's texture.
    ao_remodulate_into => AO_REMODULATE_INTO, AoRemodulateIntoBindings, AoRemodulateIntoIo: fn ao_guide::remodulate_into,
    threads(8, 8, 1), params ao_guide::GuideParams {
        input: read PackedFiltered,
        guide: read u32,
        out: storage Texel,
    }

    /// [`penumbra::penumbra_guide`]: the penumbra guide of the à-trous shadow plane, from the
    /// shadow raygen's blocker records.
    penumbra_guide => PENUMBRA_GUIDE, PenumbraGuideBindings, PenumbraGuideIo: fn penumbra::penumbra_guide,
    threads(8, 8, 1), params penumbra::PenumbraParams {
        samples: read PackedSample,
        blockers: read f32,
        depth: read Depth,
        guide: write f32,
    }

    /// [`refill::fit`]: the rays of each plane group's refill entries, so the frame stays within
    /// what it may trace; one invocation per group, after the lists.
    refill_fit => REFILL_FIT, RefillFitBindings, RefillFitIo: fn refill::fit,
    threads(64, 1, 1), params refill::FitParams {
        args: read u32,
        hist: read u32,
        decision: update Balance,
    }

    /// [`refill::cap`]: each entry of a refill list gets the rays [`refill::fit`] gave its bin;
    /// dispatch as `raygen_ao`, over the refill list.
    refill_cap => REFILL_CAP, RefillCapBindings, RefillCapIo: fn refill::cap,
    threads(64, 1, 1), params refill::CapParams {
        decision: read Balance,
        args: read u32,
        work: update WorkEntry,
    }
}
