//! A small raster engine: a `vrrt-scene` scene drawn with wgpu by the engine's own WGSL shaders
//! (`raster.wgsl`) into its own G-buffer textures, in conventions unlike VRRT's own:
//!
//! | texture | format | holds |
//! |---|---|---|
//! | [`GBufferTextures::depth`] | Depth32Float | the depth test's own z-buffer: reversed-Z device depth, infinite far plane at [`NEAR`] (0: sky) |
//! | [`GBufferTextures::normal`] | RGBA16Float | view-space shading normal (x right, y up, z towards the viewer), linear roughness in w |
//! | [`GBufferTextures::motion`] | RGBA16Float | velocity in UV units (`[0, 1]²`, y down), this frame minus last; view-depth change in z |
//! | [`GBufferTextures::hit`] | RG32Uint | geometric normal and instance, for VRRT's tracer ([`RasterEngine::copy_hits`]) |
//!
//! Why these: they are what engines write (a depth buffer, view-space normals, UV velocities),
//! and none is VRRT's own format, so the denoiser must decode every one of them
//! ([`conventions`], `Denoiser::ingest`). The denoiser reads the depth test's own z-buffer.
//!
//! The geometry drawn is the scene's meshes, each placed by its instance's transform this frame
//! and last frame, so moving objects get their own motion; the camera is the scene's. Pixel
//! centres, the two-sided surfaces and the normals' rules follow VRRT's ray-traced G-buffer
//! (`vrrt_core::kernels::gbuffer`), so both see the same surfaces and the same references apply.

pub mod agreement;
mod camera;
mod denoise;

pub use camera::{view_proj, NEAR};
pub use denoise::{open_device, AppDevice, RasterDenoiser};

use vrrt_core::glam::{Affine3A, Mat4, Vec3};
use vrrt_core::inputs::{DepthEncoding, InputConventions, MotionSign, MotionUnits, NormalSpace};
use vrrt_scene::mesh::normal_matrix;
use vrrt_scene::{FrameGeometry, Mesh, Scene};
use wgpu::util::DeviceExt;

/// The conventions of the engine's textures, for `EngineTextures::new`.
pub fn conventions() -> InputConventions {
    InputConventions {
        depth: DepthEncoding::ReversedZ,
        near: NEAR,
        normal_space: NormalSpace::View,
        motion_units: MotionUnits::Uv,
        motion_sign: MotionSign::ToCurrent,
        ..InputConventions::default()
    }
}

/// The colour targets' formats, in the shader's `@location` order.
const FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::Rgba16Float,
    wgpu::TextureFormat::Rgba16Float,
    wgpu::TextureFormat::Rg32Uint,
];

/// The engine's G-buffer: the textures its fragment shader writes.
pub struct GBufferTextures {
    /// The depth attachment of the depth test (Depth32Float, reversed Z), read by the denoiser.
    pub depth: wgpu::Texture,
    /// View-space normal and linear roughness (RGBA16Float), read by the denoiser.
    pub normal: wgpu::Texture,
    /// UV velocity and view-depth change (RGBA16Float), read by the denoiser.
    pub motion: wgpu::Texture,
    /// `packing::pack_hit` of the geometric normal and instance (RG32Uint), for the tracer.
    pub hit: wgpu::Texture,
}

impl GBufferTextures {
    fn new(device: &wgpu::Device, (width, height): (u32, u32)) -> Self {
        let texture = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | usage,
                view_formats: &[],
            })
        };
        // The denoiser samples the first three; the hits are copied into its tracer's buffer.
        let sampled = wgpu::TextureUsages::TEXTURE_BINDING;
        GBufferTextures {
            depth: texture(
                "engine z-buffer",
                wgpu::TextureFormat::Depth32Float,
                sampled,
            ),
            normal: texture("engine normals", FORMATS[0], sampled),
            motion: texture("engine velocity", FORMATS[1], sampled),
            hit: texture("engine hits", FORMATS[2], wgpu::TextureUsages::COPY_SRC),
        }
    }
}

/// One vertex as the engine stores it: object-space position, shading normal and the face
/// normal of its triangle (vertices are not shared between triangles, so each carries it).
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    face: [f32; 3],
}

/// The shader's `Frame` uniform.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
struct FrameUniform {
    view_proj: [f32; 16],
    prev_view_proj: [f32; 16],
    origin: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    size: [f32; 4],
}

/// The shader's `Instance` record.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
struct InstanceRecord {
    model: [f32; 16],
    prev_model: [f32; 16],
    normal: [f32; 16],
    params: [f32; 4],
}

/// A mesh on the GPU: a non-indexed triangle list.
struct MeshBuffer {
    vertices: wgpu::Buffer,
    count: u32,
}

/// The mesh as the engine draws it: three vertices per triangle, each with the face normal.
fn vertices(mesh: &Mesh) -> Vec<Vertex> {
    let mut out = Vec::with_capacity(mesh.indices.len() * 3);
    for tri in &mesh.indices {
        let [a, b, c] = tri.map(|i| i as usize);
        let p = [a, b, c].map(|i| mesh.positions[i]);
        let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for i in [a, b, c] {
            out.push(Vertex {
                position: mesh.positions[i].to_array(),
                normal: mesh.normals[i].to_array(),
                face: face.to_array(),
            });
        }
    }
    out
}

/// The engine: its pipeline, its scene's meshes and its G-buffer.
pub struct RasterEngine {
    queue: wgpu::Queue,
    size: (u32, u32),
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    frame: wgpu::Buffer,
    instances: wgpu::Buffer,
    meshes: Vec<MeshBuffer>,
    targets: GBufferTextures,
}

impl RasterEngine {
    /// The engine for `scene` at `size` on the application's device: uploads the meshes, builds
    /// the pipeline and the G-buffer.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        size: (u32, u32),
    ) -> Self {
        let meshes = scene
            .meshes
            .iter()
            .map(|m| MeshBuffer {
                vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("engine mesh"),
                    contents: bytemuck::cast_slice(&vertices(m)),
                    usage: wgpu::BufferUsages::VERTEX,
                }),
                count: (m.indices.len() * 3) as u32,
            })
            .collect();
        let frame = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("engine frame"),
            size: size_of::<FrameUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let instances = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("engine instances"),
            size: (scene.instances.len().max(1) * size_of::<InstanceRecord>()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pipeline = pipeline(device);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("engine"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: frame.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: instances.as_entire_binding(),
                },
            ],
        });
        RasterEngine {
            queue: queue.clone(),
            size,
            pipeline,
            bind_group,
            frame,
            instances,
            meshes,
            targets: GBufferTextures::new(device, size),
        }
    }

    /// The G-buffer textures (import the depth, normals and motion into the denoiser once).
    pub fn targets(&self) -> &GBufferTextures {
        &self.targets
    }

    /// Records the G-buffer pass of frame `f` of `scene` into `encoder` (its cameras and
    /// instance transforms are written to the queue now, so they are in place when `encoder`
    /// is submitted).
    pub fn draw(&self, encoder: &mut wgpu::CommandEncoder, scene: &Scene, f: &FrameGeometry) {
        self.write_frame(scene, f);
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let t = &self.targets;
        // Sky: depth 0 (the far plane of reversed Z), no normal, no motion, no instance.
        let no_instance = wgpu::Color {
            g: f64::from(u32::MAX),
            ..wgpu::Color::TRANSPARENT
        };
        let transparent = wgpu::Color::TRANSPARENT;
        let targets = [
            (view(&t.normal), transparent),
            (view(&t.motion), transparent),
            (view(&t.hit), no_instance),
        ];
        let colors = targets.each_ref().map(|(view, clear)| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(*clear),
                    store: wgpu::StoreOp::Store,
                },
            })
        });
        let z = view(&t.depth);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("engine G-buffer"),
            color_attachments: &colors,
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &z,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        for (i, inst) in scene.instances.iter().enumerate() {
            let mesh = &self.meshes[inst.mesh];
            pass.set_vertex_buffer(0, mesh.vertices.slice(..));
            pass.draw(0..mesh.count, i as u32..i as u32 + 1);
        }
    }

    /// Writes frame `f`'s cameras and instance transforms to the queue.
    fn write_frame(&self, scene: &Scene, f: &FrameGeometry) {
        let (w, h) = self.size;
        let c = &f.camera;
        let basis = |v: Vec3| v.extend(0.0).to_array();
        let uniform = FrameUniform {
            view_proj: view_proj(c, self.size).to_cols_array(),
            prev_view_proj: view_proj(&f.prev_camera, self.size).to_cols_array(),
            origin: basis(c.origin()),
            right: basis(c.right()),
            up: basis(c.up()),
            forward: basis(c.forward()),
            size: [w as f32, h as f32, 0.0, 0.0],
        };
        self.queue
            .write_buffer(&self.frame, 0, bytemuck::bytes_of(&uniform));
        let records = instance_records(scene, f);
        self.queue
            .write_buffer(&self.instances, 0, bytemuck::cast_slice(&records));
    }

    /// Records the copy of the hit texture into `buffer` (the tracer's `geometry` buffer of this
    /// frame, row-major `[u32; 2]` per pixel). Row by row: a texture copy's rows must start at
    /// multiples of 256 bytes in the buffer, and a row of pixels need not be one.
    pub fn copy_hits(&self, encoder: &mut wgpu::CommandEncoder, buffer: &wgpu::Buffer) {
        let (w, h) = self.size;
        for y in 0..h {
            encoder.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture: &self.targets.hit,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: 0, y, z: 0 },
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: y as u64 * w as u64 * 8,
                        bytes_per_row: None,
                        rows_per_image: None,
                    },
                },
                wgpu::Extent3d {
                    width: w,
                    height: 1,
                    depth_or_array_layers: 1,
                },
            );
        }
    }
}

/// The instances of `scene` at frame `f`: placed now and one frame earlier (the same on the
/// first frame, as `Scene::frame` has it).
fn instance_records(scene: &Scene, f: &FrameGeometry) -> Vec<InstanceRecord> {
    let prev_t = if f.index == 0 {
        f.time
    } else {
        scene.time(f.index - 1)
    };
    let mat = |m: Affine3A| Mat4::from(m).to_cols_array();
    scene
        .instances
        .iter()
        .enumerate()
        .map(|(id, inst)| {
            let now = inst.motion.at(f.time);
            let nm = normal_matrix(&now);
            InstanceRecord {
                model: mat(now),
                prev_model: mat(inst.motion.at(prev_t)),
                normal: Mat4::from_mat3(nm).to_cols_array(),
                params: [
                    inst.roughness.sqrt(),
                    now.matrix3.determinant().signum(),
                    id as f32,
                    0.0,
                ],
            }
        })
        .collect()
}

/// The engine's shaders, parsed here and given to wgpu as a naga module.
///
/// Why not as WGSL source: with `InstanceFlags::DEBUG` (which the validation runs need, for the
/// layer's messages) wgpu embeds WGSL source in the SPIR-V it makes, tagged with source language
/// 10 (WGSL), which the validation layers of Debian 12 reject as invalid SPIR-V; a module has no
/// source to embed. The WGSL is the engine's own and fixed, so a parse error is a bug: it panics.
fn shader_module(device: &wgpu::Device) -> wgpu::ShaderModule {
    let module = naga::front::wgsl::parse_str(include_str!("raster.wgsl")).unwrap_or_else(|e| {
        panic!(
            "raster.wgsl: {}",
            e.emit_to_string(include_str!("raster.wgsl"))
        )
    });
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("raster.wgsl"),
        source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(module)),
    })
}

/// The G-buffer pipeline: depth test reversed (greater is nearer), no culling (surfaces are
/// two-sided, as VRRT's tracer sees them).
fn pipeline(device: &wgpu::Device) -> wgpu::RenderPipeline {
    let module = shader_module(device);
    let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3];
    let targets = FORMATS.map(|format| Some(wgpu::ColorTargetState::from(format)));
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("engine G-buffer"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attributes,
            })],
        },
        primitive: wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}
