//! Memory: one `vkAllocateMemory` per buffer, memory types chosen by property flags, and a bump
//! allocator over host-visible chunks for uploads.

use crate::AshError;
use ash::vk;
use std::ptr::NonNull;

/// Usage of every storage buffer the executor creates.
pub(crate) const STORAGE_USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw()
        | vk::BufferUsageFlags::TRANSFER_SRC.as_raw()
        | vk::BufferUsageFlags::TRANSFER_DST.as_raw()
        | vk::BufferUsageFlags::INDIRECT_BUFFER.as_raw(),
);

/// Smallest upload chunk.
const STAGING_CHUNK: u64 = 4 << 20;

/// Index of a memory type allowed by `type_bits` with all of `required`, preferring one that also
/// has `preferred`.
pub(crate) fn memory_type(
    props: &vk::PhysicalDeviceMemoryProperties,
    type_bits: u32,
    required: vk::MemoryPropertyFlags,
    preferred: vk::MemoryPropertyFlags,
) -> Option<u32> {
    let find = |flags: vk::MemoryPropertyFlags| {
        (0..props.memory_type_count).find(|&i| {
            type_bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    };
    find(required | preferred).or_else(|| find(required))
}

/// A buffer with its own memory allocation.
pub(crate) struct Allocation {
    pub buffer: vk::Buffer,
    pub memory: vk::DeviceMemory,
}

/// Creates a buffer of `size` bytes and binds fresh memory of a type with `required` (and, if
/// possible, `preferred`) properties.
pub(crate) fn allocate(
    device: &ash::Device,
    props: &vk::PhysicalDeviceMemoryProperties,
    size: u64,
    usage: vk::BufferUsageFlags,
    required: vk::MemoryPropertyFlags,
    preferred: vk::MemoryPropertyFlags,
    what: &'static str,
) -> Result<Allocation, AshError> {
    let info = vk::BufferCreateInfo::default()
        .size(size)
        .usage(usage)
        .sharing_mode(vk::SharingMode::EXCLUSIVE);
    // SAFETY: valid device and create info.
    let buffer =
        unsafe { device.create_buffer(&info, None) }.map_err(AshError::vk("vkCreateBuffer"))?;
    // SAFETY: `buffer` was just created on `device`; on every error path it is destroyed once.
    unsafe {
        let req = device.get_buffer_memory_requirements(buffer);
        let Some(type_index) = memory_type(props, req.memory_type_bits, required, preferred) else {
            device.destroy_buffer(buffer, None);
            return Err(AshError::NoMemoryType(what));
        };
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(type_index);
        let memory = match device.allocate_memory(&alloc, None) {
            Ok(m) => m,
            Err(e) => {
                device.destroy_buffer(buffer, None);
                return Err(AshError::vk("vkAllocateMemory")(e));
            }
        };
        if let Err(e) = device.bind_buffer_memory(buffer, memory, 0) {
            device.destroy_buffer(buffer, None);
            device.free_memory(memory, None);
            return Err(AshError::vk("vkBindBufferMemory")(e));
        }
        Ok(Allocation { buffer, memory })
    }
}

impl Allocation {
    /// Destroys the buffer and frees its memory.
    ///
    /// # Safety
    /// No pending GPU work may use the buffer.
    pub unsafe fn destroy(&self, device: &ash::Device) {
        // SAFETY: caller's contract.
        unsafe {
            device.destroy_buffer(self.buffer, None);
            device.free_memory(self.memory, None);
        }
    }
}

/// A persistently mapped host-visible, host-coherent buffer.
pub(crate) struct HostBuffer {
    pub alloc: Allocation,
    pub size: u64,
    ptr: Mapped,
}

/// The mapping of a [`HostBuffer`].
struct Mapped(NonNull<u8>);
// SAFETY: the mapping is plain memory owned by the executor; access goes through `&mut self`.
unsafe impl Send for Mapped {}

impl HostBuffer {
    /// A mapped buffer for uploads (`readback == false`, source of copies) or readbacks
    /// (destination of copies, host-cached memory preferred).
    pub fn new(
        device: &ash::Device,
        props: &vk::PhysicalDeviceMemoryProperties,
        size: u64,
        readback: bool,
    ) -> Result<Self, AshError> {
        let (usage, preferred, what) = if readback {
            (
                vk::BufferUsageFlags::TRANSFER_DST,
                vk::MemoryPropertyFlags::HOST_CACHED,
                "readback",
            )
        } else {
            (
                vk::BufferUsageFlags::TRANSFER_SRC,
                vk::MemoryPropertyFlags::empty(),
                "upload",
            )
        };
        // Every implementation has a HOST_VISIBLE | HOST_COHERENT type, so no flush/invalidate.
        let required =
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
        let alloc = allocate(device, props, size, usage, required, preferred, what)?;
        // SAFETY: memory is host-visible and not mapped yet.
        let ptr = unsafe {
            device.map_memory(alloc.memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())
        };
        match ptr.map(|p| NonNull::new(p.cast::<u8>())) {
            Ok(Some(p)) => Ok(HostBuffer {
                alloc,
                size,
                ptr: Mapped(p),
            }),
            Ok(None) | Err(_) => {
                // SAFETY: never used by the GPU.
                unsafe { alloc.destroy(device) };
                Err(AshError::Vulkan {
                    call: "vkMapMemory",
                    result: ptr.err().unwrap_or(vk::Result::ERROR_MEMORY_MAP_FAILED),
                })
            }
        }
    }

    /// Copies `data` to byte `offset`.
    pub fn write(&mut self, offset: u64, data: &[u8]) {
        assert!(offset + data.len() as u64 <= self.size);
        // SAFETY: in bounds of the mapping (checked); the GPU does not access this range now.
        unsafe {
            std::ptr::copy_nonoverlapping(
                data.as_ptr(),
                self.ptr.0.as_ptr().add(offset as usize),
                data.len(),
            )
        };
    }

    /// Copies the first `out.len()` bytes out.
    pub fn read(&self, out: &mut [u8]) {
        assert!(out.len() as u64 <= self.size);
        // SAFETY: in bounds of the mapping (checked); GPU writes completed (fence waited).
        unsafe { std::ptr::copy_nonoverlapping(self.ptr.0.as_ptr(), out.as_mut_ptr(), out.len()) };
    }

    /// Unmaps, destroys and frees.
    ///
    /// # Safety
    /// No pending GPU work may use the buffer.
    pub unsafe fn destroy(&self, device: &ash::Device) {
        // SAFETY: caller's contract; freeing memory implicitly unmaps it.
        unsafe { self.alloc.destroy(device) };
    }
}

/// Bump allocator over upload chunks, reset once the work that reads them has completed.
#[derive(Default)]
pub(crate) struct Staging {
    chunks: Vec<HostBuffer>,
    /// Chunk being filled.
    current: usize,
    /// Bytes used in it.
    used: u64,
}

impl Staging {
    /// Copies `data` into staging memory; returns the staging buffer and offset to copy from.
    pub fn push(
        &mut self,
        device: &ash::Device,
        props: &vk::PhysicalDeviceMemoryProperties,
        data: &[u8],
    ) -> Result<(vk::Buffer, u64), AshError> {
        let len = data.len() as u64;
        loop {
            match self.chunks.get_mut(self.current) {
                Some(chunk) if self.used + len <= chunk.size => {
                    let offset = self.used;
                    chunk.write(offset, data);
                    self.used = (offset + len).next_multiple_of(16);
                    return Ok((chunk.alloc.buffer, offset));
                }
                Some(_) => {
                    self.current += 1;
                    self.used = 0;
                }
                None => {
                    let size = len.max(STAGING_CHUNK).next_multiple_of(STAGING_CHUNK);
                    self.chunks
                        .push(HostBuffer::new(device, props, size, false)?);
                    self.current = self.chunks.len() - 1;
                    self.used = 0;
                }
            }
        }
    }

    /// Makes all chunks free again (their copies have completed).
    pub fn reset(&mut self) {
        self.current = 0;
        self.used = 0;
    }

    /// Destroys every chunk.
    ///
    /// # Safety
    /// No pending GPU work may read them.
    pub unsafe fn destroy(&mut self, device: &ash::Device) {
        for c in self.chunks.drain(..) {
            // SAFETY: caller's contract.
            unsafe { c.destroy(device) };
        }
        self.reset();
    }
}
