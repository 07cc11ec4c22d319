//! Valid seed files of the mesh fuzz test: the kept corpus (`tests/corpus`) and small files
//! generated here (OBJ, ASCII and binary PLY in both byte orders, glTF with data-URI and external
//! buffers, GLB), with the tokens of each format that the mutator inserts.

use std::io::Write;
use std::path::Path;

pub fn corpus(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/corpus")
            .join(name),
    )
    .unwrap()
}

pub fn obj_seeds() -> Vec<Vec<u8>> {
    let mut seeds = vec![
        corpus("quad.obj"),
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
        b"# tetrahedron\nmtllib tetra.mtl\no tetra\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n\
          vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 -1\nvn 0 -1 0\nvn -1 0 0\nvn 0.577 0.577 0.577\n\
          g side\nusemtl a\ns 1\nf 1/1/1 3/3/1 2/2/1\nf 1/1/2 2/2/2 4/3/2\ns off\nf 1//3 4//3 3//3\n\
          f 2/2 3/3 4/1\n"
            .to_vec(),
        b"v -1.5 0.25e1 3\r\nv 2 -0.5 1.0 1.0\r\nv 0.5 1E1 -2\r\nv 1 1 1\r\nv 0 2 2\r\n\
          f 1 2 3 4 5\r\nf -1 -2 -3\r\nl 1 2\r\np 3\r\n"
            .to_vec(),
        // A byte-order mark (issue 47: it shifted every index).
        b"\xEF\xBB\xBFv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 1 1\nf 1 2 3\n".to_vec(),
    ];
    // A larger mesh: a 6 × 6 grid of quads.
    let mut grid = String::new();
    for y in 0..7 {
        for x in 0..7 {
            grid += &format!("v {x} {y} {}\n", (x * y) as f32 * 0.1);
        }
    }
    for y in 0..6 {
        for x in 0..6 {
            let a = y * 7 + x + 1;
            grid += &format!("f {a} {} {} {}\n", a + 1, a + 8, a + 7);
        }
    }
    seeds.push(grid.into_bytes());
    seeds
}

pub const OBJ_WORDS: &[&str] = &[
    "v ", "vn ", "vt ", "f ", "o ", "g ", "s ", "l ", "usemtl ", "mtllib ", "/", "//", "\n",
    "\r\n", " ", "#", "\\\n", "-",
];

/// A PLY header; `format` is `ascii`, `binary_little_endian` or `binary_big_endian`.
fn ply_header(format: &str, vertex_props: &str, nv: usize, face_list: &str, nf: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment made by the fuzz test\nelement vertex {nv}\n\
         {vertex_props}element face {nf}\nproperty list {face_list} vertex_indices\nend_header\n"
    )
}

const TETRA: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
const TETRA_FACES: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

pub fn ply_ascii_seeds() -> Vec<Vec<u8>> {
    let xyz = "property float x\nproperty float y\nproperty float z\n";
    let mut with_normals = ply_header(
        "ascii",
        &format!("{xyz}property float nx\nproperty float ny\nproperty float nz\n"),
        4,
        "uchar int",
        4,
    );
    for p in TETRA {
        with_normals += &format!("{} {} {} 0 0 1\n", p[0], p[1], p[2]);
    }
    for f in TETRA_FACES {
        with_normals += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    let mut doubles = ply_header(
        "ascii",
        "property double x\nproperty double y\nproperty double z\nproperty uchar red\n\
         property uchar green\nproperty uchar blue\n",
        5,
        "uint8 int32",
        2,
    )
    .replace(
        "end_header",
        "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header",
    );
    doubles += "0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 1 2 3\n0.5 1.5 -1e-3 9 9 9\n\
                4 0 1 2 3\n3 2 3 4\n0 1\n";
    let crlf = "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\n\
                property float y\r\nproperty float z\r\nelement face 1\r\n\
                property list uchar uint vertex_indices\r\nend_header\r\n0 0 0\r\n1 0 0\r\n\
                0 1 0\r\n3 0 1 2\r\n";
    vec![
        corpus("cube_ascii.ply"),
        with_normals.into_bytes(),
        doubles.into_bytes(),
        crlf.as_bytes().to_vec(),
    ]
}

pub fn ply_binary_seeds() -> Vec<Vec<u8>> {
    let xyz = "property float x\nproperty float y\nproperty float z\n";
    let mut seeds = vec![corpus("tri_le.ply")];
    for (format, be) in [("binary_little_endian", false), ("binary_big_endian", true)] {
        let f32b = |v: f32| if be { v.to_be_bytes() } else { v.to_le_bytes() };
        let u32b = |v: u32| if be { v.to_be_bytes() } else { v.to_le_bytes() };
        let mut b = ply_header(format, xyz, 4, "uchar uint", 4).into_bytes();
        for p in TETRA {
            for c in p {
                b.extend_from_slice(&f32b(c));
            }
        }
        for f in TETRA_FACES {
            b.push(3);
            for i in f {
                b.extend_from_slice(&u32b(i));
            }
        }
        seeds.push(b);
    }
    // Doubles, a ushort list count, short indices, an extra property and element.
    let mut b = ply_header(
        "binary_little_endian",
        "property double x\nproperty double y\nproperty double z\nproperty uchar flags\n",
        4,
        "ushort short",
        1,
    )
    .replace("end_header", "element extra 1\nproperty int n\nend_header")
    .into_bytes();
    for p in [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        for c in p {
            b.extend_from_slice(&f64::to_le_bytes(c));
        }
        b.push(7);
    }
    b.extend_from_slice(&4u16.to_le_bytes());
    for i in [0i16, 1, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b.extend_from_slice(&42i32.to_le_bytes());
    seeds.push(b);
    seeds
}

pub const PLY_WORDS: &[&str] = &[
    "ply\n",
    "format ascii 1.0\n",
    "format binary_little_endian 1.0\n",
    "format binary_big_endian 1.0\n",
    "element ",
    "vertex ",
    "face ",
    "property ",
    "list ",
    "char ",
    "uchar ",
    "short ",
    "ushort ",
    "int ",
    "uint ",
    "float ",
    "double ",
    "int8 ",
    "uint32 ",
    "float64 ",
    "vertex_indices\n",
    "vertex_index\n",
    "x\n",
    "nx\n",
    "comment ",
    "obj_info ",
    "end_header\n",
    "\n",
    " ",
];

pub fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

/// glTF seeds: `(json, bin)` pairs, the buffer 0 of each document being `bin`. The JSON names
/// buffer 0 with the placeholder `"BUFFER"` (its `byteLength` and, for `.gltf`, its `uri` are
/// filled in by [`gltf_text`] or [`glb`]).
pub fn gltf_docs() -> Vec<(String, Vec<u8>)> {
    let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let mut docs = Vec::new();

    // Indexed quad: u32 indices, normals, a parent with TRS and a child with a matrix.
    let mut bin = f32s(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]);
    bin.extend(f32s(&[0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.]));
    bin.extend([0u32, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    docs.push((
        r#"{"asset":{"version":"2.0","generator":"fuzz"},"scene":0,"scenes":[{"nodes":[0]}],
"nodes":[{"children":[1],"translation":[0,1,0],"rotation":[0,0,0.7071068,0.7071068],"scale":[2,2,2]},
{"mesh":0,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0.5,0,0,1]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1},"indices":2,"mode":4}]}],
"buffers":[BUFFER],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":48},
{"buffer":0,"byteOffset":96,"byteLength":24,"target":34963}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"},
{"bufferView":2,"componentType":5125,"count":6,"type":"SCALAR"}]}"#
            .to_string(),
        bin,
    ));

    // Non-indexed, interleaved (stride 24) positions and normals, u8-indexed second primitive,
    // no default scene, one mesh placed by two nodes.
    let mut bin = Vec::new();
    for p in TETRA.iter().take(3) {
        bin.extend(f32s(p));
        bin.extend(f32s(&[0., 0., 1.]));
    }
    bin.extend([0u8, 1, 2, 0]);
    docs.push((
        r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0,1]}],
"nodes":[{"mesh":0},{"mesh":0,"translation":[3,0,0]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1}},
{"attributes":{"POSITION":0},"indices":2}]}],
"buffers":[BUFFER],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":72,"byteStride":24},
{"buffer":0,"byteOffset":72,"byteLength":3}],
"accessors":[{"bufferView":0,"byteOffset":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":0,"byteOffset":12,"componentType":5126,"count":3,"type":"VEC3"},
{"bufferView":1,"componentType":5121,"count":3,"type":"SCALAR"}]}"#
            .to_string(),
        bin,
    ));

    // No scenes at all (root nodes are used), u16 indices, a triangle fan.
    let mut bin = f32s(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]);
    bin.extend([0u16, 1, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    docs.push((
        r#"{"asset":{"version":"2.0"},
"nodes":[{"children":[1]},{"mesh":0,"scale":[1,1,1]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":6}]},
{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":4}]}],
"buffers":[BUFFER],
"bufferViews":[{"buffer":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":8}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5123,"count":4,"type":"SCALAR"}]}"#
            .to_string(),
        bin,
    ));
    docs
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A `.gltf` with buffer 0 in a data URI.
pub fn gltf_text(json: &str, bin: &[u8]) -> Vec<u8> {
    let buffer = format!(
        r#"{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}"#,
        bin.len(),
        base64(bin)
    );
    json.replace("BUFFER", &buffer).into_bytes()
}

/// A `.gltf` with buffer 0 in the file `buffer.bin` beside it.
pub fn gltf_external(json: &str, bin: &[u8]) -> Vec<u8> {
    let buffer = format!(r#"{{"byteLength":{},"uri":"buffer.bin"}}"#, bin.len());
    json.replace("BUFFER", &buffer).into_bytes()
}

/// A `.glb` with buffer 0 in its BIN chunk.
pub fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json
        .replace("BUFFER", &format!(r#"{{"byteLength":{}}}"#, bin.len()))
        .into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

pub const GLTF_WORDS: &[&str] = &[
    "{",
    "}",
    "[",
    "]",
    ",",
    ":",
    "\"",
    "null",
    "true",
    "-1",
    "0",
    "\"count\":",
    "\"byteOffset\":",
    "\"byteLength\":",
    "\"byteStride\":",
    "\"bufferView\":",
    "\"buffer\":",
    "\"indices\":",
    "\"mode\":",
    "\"mesh\":",
    "\"children\":[0]",
    "\"matrix\":[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0]",
    "\"sparse\":{\"count\":1}",
    "\"componentType\":5126",
    "\"componentType\":5125",
    "\"type\":\"VEC3\"",
    "\"type\":\"MAT4\"",
    "\"uri\":\"buffer.bin\"",
    "\"uri\":\"missing.bin\"",
    "\"uri\":\"data:,\"",
    "\"uri\":\"http://example.com/x.bin\"",
    "%2e%2e/",
    "\\u0000",
    "\\\"",
];
