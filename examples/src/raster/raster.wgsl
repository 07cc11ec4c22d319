// The raster engine's G-buffer pass: its own conventions, not VRRT's (see mod.rs).
//
// Outputs per pixel, besides the reversed-Z depth of the depth test (near / view depth; 0 = sky):
//   0  RGBA16Float  view-space shading normal (x right, y up, z towards the viewer), linear
//                   roughness in w
//   1  RGBA16Float  velocity in UV units ([0,1]², y down), this frame minus last, and the view
//                   depth change (this frame minus last) in z
//   2  RG32Uint     what VRRT's built-in tracer reads besides the denoiser's inputs: the
//                   geometric normal (octahedral 16 + 16 bits) and the instance, as
//                   `vrrt_core::packing::pack_hit` packs them

struct Frame {
    view_proj: mat4x4<f32>,
    prev_view_proj: mat4x4<f32>,
    // Camera basis of this frame (w unused).
    origin: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    // Image width and height in pixels (zw unused).
    size: vec4<f32>,
}

struct Instance {
    // Object to world, this frame and last frame.
    model: mat4x4<f32>,
    prev_model: mat4x4<f32>,
    // Inverse transpose of the linear part (upper 3x3).
    normal: mat4x4<f32>,
    // x: linear roughness; y: sign of the linear part's determinant (a mirror turns faces);
    // z: instance id (as a float: exact below 2^24).
    params: vec4<f32>,
}

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> instances: array<Instance>;

struct Vertex {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    // The triangle's face normal (the same at its three corners).
    @location(2) face: vec3<f32>,
}

struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) face: vec3<f32>,
    @location(3) prev_clip: vec4<f32>,
    @location(4) @interpolate(flat) params: vec4<f32>,
}

fn normal_to_world(inst: Instance, n: vec3<f32>) -> vec3<f32> {
    return mat3x3<f32>(inst.normal[0].xyz, inst.normal[1].xyz, inst.normal[2].xyz) * n;
}

@vertex
fn vs_main(v: Vertex, @builtin(instance_index) i: u32) -> Varyings {
    let inst = instances[i];
    let world = inst.model * vec4<f32>(v.position, 1.0);
    let n = normal_to_world(inst, v.normal);
    let len = length(n);
    var out: Varyings;
    out.position = frame.view_proj * world;
    out.world = world.xyz;
    out.normal = select(vec3<f32>(0.0, 1.0, 0.0), n / len, len > 0.0);
    // The face normal of the world-space triangle: a mirror reverses its winding.
    out.face = normal_to_world(inst, v.face) * inst.params.y;
    out.prev_clip = frame.prev_view_proj * (inst.prev_model * vec4<f32>(v.position, 1.0));
    out.params = inst.params;
    return out;
}

struct Targets {
    @location(0) normal: vec4<f32>,
    @location(1) motion: vec4<f32>,
    @location(2) hit: vec2<u32>,
}

fn oct_encode(n: vec3<f32>) -> vec2<f32> {
    let l1 = abs(n.x) + abs(n.y) + abs(n.z);
    let p = n.xy * select(0.0, 1.0 / l1, l1 > 0.0);
    if n.z >= 0.0 {
        return p;
    }
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    return (vec2<f32>(1.0) - abs(p.yx)) * s;
}

fn code16(v: f32) -> u32 {
    return u32(floor((clamp(v, -1.0, 1.0) + 1.0) / 2.0 * 65535.0 + 0.5));
}

@fragment
fn fs_main(in: Varyings) -> Targets {
    let to_point = in.world - frame.origin.xyz;
    // Two-sided surfaces: both normals face the camera, turned together by the face normal.
    var g = normalize(in.face);
    let len = length(in.normal);
    var n = select(g, in.normal / len, len > 0.0);
    if dot(g, to_point) > 0.0 {
        g = -g;
        n = -n;
    }
    var out: Targets;
    let view_n = vec3<f32>(dot(n, frame.right.xyz), dot(n, frame.up.xyz), -dot(n, frame.forward.xyz));
    out.normal = vec4<f32>(view_n, in.params.x);
    // Velocity: where the point is now minus where it was, in UV; a point that was behind the
    // camera gets a velocity far off the image.
    let uv = in.position.xy / frame.size.xy;
    let prev_ndc = in.prev_clip.xy / in.prev_clip.w;
    let prev_uv = vec2<f32>(prev_ndc.x * 0.5 + 0.5, 0.5 - prev_ndc.y * 0.5);
    let velocity = select(vec2<f32>(1.0e4), uv - prev_uv, in.prev_clip.w > 1.0e-12);
    let depth_change = dot(to_point, frame.forward.xyz) - in.prev_clip.w;
    out.motion = vec4<f32>(velocity, depth_change, 0.0);
    let e = oct_encode(g);
    out.hit = vec2<u32>(code16(e.x) | (code16(e.y) << 16u), u32(in.params.z));
    return out;
}
