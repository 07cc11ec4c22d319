//! The engine-embedding path: an executor borrowing another device ([`AshExecutor::from_raw`]),
//! recording passes into a command buffer the "engine" owns and submits, on a buffer the engine
//! imports. The engine here is a headless executor whose device and validation messenger are
//! borrowed, so validation covers the borrowed path too.

mod common;

use common::executor as host;
use vrrt_ash::ash::vk;
use vrrt_ash::{AshError, AshExecutor, RawVulkan};
use vrrt_core::executor::{Executor, Pass};
use vrrt_core::kernels::buckets::{BucketParams, BUCKET_COUNT, COUNTS_LEN};
use vrrt_cpu::CpuExecutor;

#[test]
fn record_into_engine_command_buffer() {
    let Some(mut engine) = host() else { return };
    let (w, h) = (133u32, 71u32);
    let requests: Vec<u32> = (0..w * h)
        .map(|i| (i.wrapping_mul(2_654_435_761u32) >> 7) % (BUCKET_COUNT + 3))
        .collect();
    let params = BucketParams {
        width: w,
        height: h,
    };

    // The "engine" owns a counts buffer (created here through the host executor for brevity).
    let engine_counts = engine.create_buffer(u64::from(COUNTS_LEN) * 4).unwrap();
    engine.finish().unwrap();
    let engine_vk_counts = engine.raw_buffer(engine_counts).unwrap();

    let raw = RawVulkan {
        instance: engine.instance().clone(),
        device: engine.device().clone(),
        physical_device: engine.physical_device(),
        queue: engine.queue(),
        queue_family_index: engine.queue_family_index(),
    };
    // SAFETY: the engine executor's handles outlive `ex` (dropped first, below); vulkanMemoryModel
    // is enabled by new_headless; only this thread uses the queue.
    let mut ex = unsafe { AshExecutor::from_raw(raw) }.unwrap();
    assert_eq!(ex.validation_errors(), 0);
    let req = ex.create_buffer(u64::from(w * h) * 4).unwrap();
    ex.write_buffer(req, bytemuck::cast_slice(&requests))
        .unwrap();
    // SAFETY: the buffer has all usages and outlives `ex`.
    let counts = unsafe { ex.import_buffer(engine_vk_counts, u64::from(COUNTS_LEN) * 4) }.unwrap();
    assert_eq!(ex.raw_buffer(counts).unwrap(), engine_vk_counts);

    // The engine's command pool, command buffer and fence.
    let d = engine.device().clone();
    let (pool, cmd, fence) = command_objects(&d, engine.queue_family_index());
    let bufs = [req, counts];
    let pass = Pass::over_grid(
        &vrrt_core::kernels::COUNT_BUCKETS,
        &bufs,
        bytemuck::bytes_of(&params),
        w,
        h,
        1,
    );
    let mut timed = 0;
    for frame in 0..3 {
        // SAFETY: cmd is recording and submitted to the executor's queue below; the recording is
        // retired after the fence wait.
        unsafe {
            d.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())
                .unwrap();
            // Two passes: the second must see the first's atomics (barrier inserted by `ex`).
            let rec = ex.record_into(cmd, &[pass, pass]).unwrap();
            assert_eq!(rec.passes(), 2);
            // What the engine inserts after: make the counts visible to its transfer read.
            shader_writes_to_transfer(&d, cmd, engine_vk_counts);
            d.end_command_buffer(cmd).unwrap();
            let cmds = [cmd];
            d.queue_submit(
                engine.queue(),
                &[vk::SubmitInfo::default().command_buffers(&cmds)],
                fence,
            )
            .unwrap();
            d.wait_for_fences(&[fence], true, u64::MAX).unwrap();
            d.reset_fences(&[fence]).unwrap();
            d.reset_command_pool(pool, vk::CommandPoolResetFlags::empty())
                .unwrap();
            ex.retire(rec).unwrap();
        }
        timed = ex.timings().len();
        // Engine reads the counts through its own executor: 2 × (frame + 1) passes' worth.
        let mut gpu = vec![0u32; COUNTS_LEN as usize];
        engine
            .read_buffer(engine_counts, bytemuck::cast_slice_mut(&mut gpu))
            .unwrap();
        let want = cpu_counts(&requests, &params, 2 * (frame + 1));
        assert_eq!(gpu, want, "frame {frame}");
    }
    check_timestamps(&ex, timed);
    buffers_in_use_are_kept(&mut ex, &d, cmd, pass, req);
    ex.destroy_buffer(req).unwrap();
    ex.destroy_buffer(counts).unwrap(); // imported: only forgotten
    drop(ex);
    unsafe {
        d.destroy_fence(fence, None);
        d.destroy_command_pool(pool, None);
    }
    assert_eq!(
        engine.validation_errors(),
        0,
        "validation reported errors (see stderr)"
    );
}

/// Records the barrier that makes compute-shader writes to `buffer` visible to a transfer read.
///
/// # Safety
/// `cmd` is recording on `d`, and `buffer` is a buffer of `d`.
unsafe fn shader_writes_to_transfer(
    d: &vrrt_ash::ash::Device,
    cmd: vk::CommandBuffer,
    buffer: vk::Buffer,
) {
    let after = vk::BufferMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::SHADER_WRITE)
        .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .buffer(buffer)
        .size(vk::WHOLE_SIZE);
    // SAFETY: the caller's contract.
    unsafe {
        d.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::PipelineStageFlags::TRANSFER,
            vk::DependencyFlags::empty(),
            &[],
            &[after],
            &[],
        );
    }
}

/// The engine's command pool, one command buffer from it and a fence.
fn command_objects(
    d: &vrrt_ash::ash::Device,
    queue_family_index: u32,
) -> (vk::CommandPool, vk::CommandBuffer, vk::Fence) {
    // SAFETY: a live device; the objects are destroyed by the test before the device.
    unsafe {
        let pool = d
            .create_command_pool(
                &vk::CommandPoolCreateInfo::default().queue_family_index(queue_family_index),
                None,
            )
            .unwrap();
        let cmd = d
            .allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(pool)
                    .command_buffer_count(1),
            )
            .unwrap()[0];
        let fence = d
            .create_fence(&vk::FenceCreateInfo::default(), None)
            .unwrap();
        (pool, cmd, fence)
    }
}

/// The counts `passes` bucket-count passes over `requests` leave on the CPU backend: what the
/// engine's buffer must hold.
fn cpu_counts(requests: &[u32], params: &BucketParams, passes: u32) -> Vec<u32> {
    let (w, h) = (params.width, params.height);
    let mut cpu = CpuExecutor::new();
    let (r, c) = (
        cpu.create_buffer(u64::from(w * h) * 4).unwrap(),
        cpu.create_buffer(u64::from(COUNTS_LEN) * 4).unwrap(),
    );
    cpu.write_buffer(r, bytemuck::cast_slice(requests)).unwrap();
    let cb = [r, c];
    for _ in 0..passes {
        cpu.dispatch(&Pass::over_grid(
            &vrrt_core::kernels::COUNT_BUCKETS,
            &cb,
            bytemuck::bytes_of(params),
            w,
            h,
            1,
        ))
        .unwrap();
    }
    let mut want = vec![0u32; COUNTS_LEN as usize];
    cpu.read_buffer(c, bytemuck::cast_slice_mut(&mut want))
        .unwrap();
    want
}

/// With timestamps, each of the 6 passes recorded into the engine's buffers was timed.
fn check_timestamps(ex: &AshExecutor, timed: usize) {
    if ex.adapter_info().timestamps {
        assert_eq!(timed, 6);
        assert!(
            ex.timings().iter().all(|t| t.ms > 0.0),
            "{:?}",
            ex.timings()
        );
    }
}

/// A buffer used by an unretired recording cannot be destroyed; retired (even unsubmitted),
/// it can.
fn buffers_in_use_are_kept(
    ex: &mut AshExecutor,
    d: &vrrt_ash::ash::Device,
    cmd: vk::CommandBuffer,
    pass: Pass<'_>,
    req: vrrt_core::executor::BufferId,
) {
    // SAFETY: `cmd` is not in use (its last submission was waited for) and is never submitted.
    unsafe {
        d.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())
            .unwrap();
        let rec = ex.record_into(cmd, &[pass]).unwrap();
        d.end_command_buffer(cmd).unwrap();
        assert!(matches!(
            ex.destroy_buffer(req),
            Err(AshError::BufferInUse(_))
        ));
        ex.retire(rec).unwrap(); // never submitted: allowed
    }
}
