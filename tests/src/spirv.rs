//! Just enough SPIR-V reflection to check that the shipped module matches the kernel
//! descriptions in `vrrt-core`: every entry point exists, with the same workgroup size, the same
//! storage-buffer and texture bindings, and push constants exactly when the kernel declares
//! parameters.

use std::collections::{BTreeSet, HashMap};

/// What the module says about one compute entry point.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EntryPoint {
    /// Entry point name.
    pub name: String,
    /// `LocalSize` execution mode.
    pub local_size: [u32; 3],
    /// Storage-buffer bindings in descriptor set 0 used by the entry point.
    pub bindings: BTreeSet<u32>,
    /// Image (texture) bindings in descriptor set 0 used by the entry point.
    pub textures: BTreeSet<u32>,
    /// Whether the entry point uses a push-constant block.
    pub push_constants: bool,
}

const OP_ENTRY_POINT: u16 = 15;
const OP_EXECUTION_MODE: u16 = 16;
const OP_VARIABLE: u16 = 59;
const OP_DECORATE: u16 = 71;
const MODE_LOCAL_SIZE: u32 = 17;
const DECORATION_BINDING: u32 = 33;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
const STORAGE_UNIFORM_CONSTANT: u32 = 0;
const STORAGE_PUSH_CONSTANT: u32 = 9;
const STORAGE_STORAGE_BUFFER: u32 = 12;

fn literal_string(words: &[u32]) -> (String, usize) {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    (
        String::from_utf8_lossy(&bytes[..end]).into_owned(),
        end / 4 + 1,
    )
}

/// Parses the compute entry points of a SPIR-V module.
pub fn entry_points(module: &[u8]) -> Result<Vec<EntryPoint>, String> {
    if !module.len().is_multiple_of(4) || module.len() < 20 {
        return Err("not a SPIR-V module: bad length".into());
    }
    let words: Vec<u32> = module
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if words[0] != 0x0723_0203 {
        return Err("not a SPIR-V module: bad magic".into());
    }
    let mut entries: Vec<(u32, EntryPoint, Vec<u32>)> = Vec::new();
    let mut local_size: HashMap<u32, [u32; 3]> = HashMap::new();
    let mut storage: HashMap<u32, u32> = HashMap::new();
    let mut binding: HashMap<u32, u32> = HashMap::new();
    let mut set: HashMap<u32, u32> = HashMap::new();
    let mut i = 5;
    while i < words.len() {
        let (count, op) = ((words[i] >> 16) as usize, (words[i] & 0xffff) as u16);
        if count == 0 || i + count > words.len() {
            return Err(format!("truncated instruction at word {i}"));
        }
        let args = &words[i + 1..i + count];
        match op {
            OP_ENTRY_POINT if args.len() >= 3 => {
                let (name, used) = literal_string(&args[2..]);
                let interface = args[2 + used..].to_vec();
                entries.push((
                    args[1],
                    EntryPoint {
                        name,
                        ..Default::default()
                    },
                    interface,
                ));
            }
            OP_EXECUTION_MODE if args.len() >= 5 && args[1] == MODE_LOCAL_SIZE => {
                local_size.insert(args[0], [args[2], args[3], args[4]]);
            }
            OP_VARIABLE if args.len() >= 3 => {
                storage.insert(args[1], args[2]);
            }
            OP_DECORATE if args.len() >= 3 && args[1] == DECORATION_BINDING => {
                binding.insert(args[0], args[2]);
            }
            OP_DECORATE if args.len() >= 3 && args[1] == DECORATION_DESCRIPTOR_SET => {
                set.insert(args[0], args[2]);
            }
            _ => {}
        }
        i += count;
    }
    Ok(entries
        .into_iter()
        .map(|(function, mut e, interface)| {
            e.local_size = local_size.get(&function).copied().unwrap_or_default();
            for var in interface {
                match storage.get(&var) {
                    Some(&STORAGE_STORAGE_BUFFER) if set.get(&var) == Some(&0) => {
                        if let Some(&b) = binding.get(&var) {
                            e.bindings.insert(b);
                        }
                    }
                    Some(&STORAGE_UNIFORM_CONSTANT) if set.get(&var) == Some(&0) => {
                        if let Some(&b) = binding.get(&var) {
                            e.textures.insert(b);
                        }
                    }
                    Some(&STORAGE_PUSH_CONSTANT) => e.push_constants = true,
                    _ => {}
                }
            }
            e
        })
        .collect())
}
