//! The embedded SPIR-V module and the little of it the backend needs to know up front: entry point
//! names (to report a missing one as an error instead of a driver crash) and declared capabilities
//! (to enable the matching device features).

use crate::AshError;

/// The module built by `shaders-builder` (all entry points of `vrrt-shaders`), shipped by
/// `vrrt-spirv`.
pub(crate) use vrrt_spirv::SPIRV;

const MAGIC: u32 = 0x0723_0203;
const OP_ENTRY_POINT: u32 = 15;
const OP_CAPABILITY: u32 = 17;

/// SPIR-V capabilities that map to device features.
pub(crate) mod cap {
    pub const FLOAT16: u32 = 9;
    pub const FLOAT64: u32 = 10;
    pub const INT64: u32 = 11;
    pub const INT16: u32 = 22;
    pub const INT8: u32 = 39;
    pub const STORAGE_BUFFER_16BIT_ACCESS: u32 = 4433;
    pub const STORAGE_BUFFER_8BIT_ACCESS: u32 = 4448;
    pub const VULKAN_MEMORY_MODEL_DEVICE_SCOPE: u32 = 5346;
}

/// What the backend reads from a module.
#[derive(Debug, Default)]
pub(crate) struct ModuleInfo {
    /// The module's words, host-endian.
    pub words: Vec<u32>,
    /// `OpEntryPoint` names.
    pub entry_points: Vec<String>,
    /// `OpCapability` operands.
    pub capabilities: Vec<u32>,
}

impl ModuleInfo {
    pub fn has_capability(&self, c: u32) -> bool {
        self.capabilities.contains(&c)
    }
}

/// Decodes a SPIR-V binary (either endianness, any alignment).
pub(crate) fn parse(bytes: &[u8]) -> Result<ModuleInfo, AshError> {
    let words = ash::util::read_spv(&mut std::io::Cursor::new(bytes))
        .map_err(|e| AshError::BadSpirv(e.to_string()))?;
    if words.len() < 5 || words[0] != MAGIC {
        return Err(AshError::BadSpirv("bad header".into()));
    }
    let mut info = ModuleInfo::default();
    let mut i = 5;
    while i < words.len() {
        let op = words[i] & 0xffff;
        let n = (words[i] >> 16) as usize;
        if n == 0 || i + n > words.len() {
            return Err(AshError::BadSpirv(format!(
                "truncated instruction at word {i}"
            )));
        }
        match op {
            OP_CAPABILITY if n >= 2 => info.capabilities.push(words[i + 1]),
            OP_ENTRY_POINT if n >= 4 => {
                let bytes: Vec<u8> = words[i + 3..i + n]
                    .iter()
                    .flat_map(|w| w.to_le_bytes())
                    .collect();
                let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                info.entry_points
                    .push(String::from_utf8_lossy(&bytes[..end]).into_owned());
            }
            _ => {}
        }
        i += n;
    }
    info.words = words;
    Ok(info)
}
