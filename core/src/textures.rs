//! The engine's textures as kernels see them: [`Fetch`] reads a texel (a sampled image on the
//! GPU, [`Texture`] on the CPU), [`Store`] writes one (a storage image on the GPU,
//! [`TextureOut`] on the CPU). Kernels take each texture binding as an `impl Fetch` or
//! `impl Store` argument after their buffers, since Vulkan does not let a struct hold an image.

use core::cell::Cell;
use glam::Vec4;

/// An engine texture a kernel reads: what a texel fetch returns.
pub trait Fetch {
    /// Texel `(x, y)` of a texture `width` texels wide.
    fn load(&self, x: u32, y: u32, width: u32) -> Vec4;
}

/// A texel as the CPU backend holds an engine texture: what a fetch returns (RGBA, unorm formats
/// in `[0, 1]`, missing channels 0 and alpha 1).
pub type Texel = [f32; 4];

/// An engine texture on the CPU: row-major [`Texel`]s.
#[derive(Copy, Clone, Debug)]
pub struct Texture<'a> {
    texels: &'a [Texel],
}

impl<'a> Texture<'a> {
    /// A texture of `texels`, row-major.
    #[inline]
    pub fn new(texels: &'a [Texel]) -> Self {
        Texture { texels }
    }
}

impl Fetch for Texture<'_> {
    #[inline]
    fn load(&self, x: u32, y: u32, width: u32) -> Vec4 {
        Vec4::from_array(self.texels[(y * width + x) as usize])
    }
}

/// The SPIR-V type of an engine texture binding.
#[cfg(target_arch = "spirv")]
pub type SampledImage = spirv_std::Image!(2D, type = f32, sampled = true);

/// Natively, where the shader crate's entry points are only type-checked, a CPU texture.
#[cfg(not(target_arch = "spirv"))]
pub type SampledImage = Texture<'static>;

impl Fetch for &Texture<'_> {
    #[inline]
    fn load(&self, x: u32, y: u32, width: u32) -> Vec4 {
        (**self).load(x, y, width)
    }
}

#[cfg(target_arch = "spirv")]
impl Fetch for &SampledImage {
    #[inline]
    fn load(&self, x: u32, y: u32, _width: u32) -> Vec4 {
        self.fetch(glam::UVec2::new(x, y))
    }
}

/// An engine texture a kernel writes (the denoised output). Through a shared reference, as a
/// storage image is written on the GPU: each invocation writes only its own pixels' texels.
pub trait Store {
    /// Writes texel `(x, y)` of a texture `width` texels wide.
    fn store(&self, x: u32, y: u32, width: u32, value: Vec4);
}

/// An engine texture the CPU writes: row-major [`Texel`]s.
#[derive(Debug)]
pub struct TextureOut<'a> {
    texels: &'a [Cell<Texel>],
}

impl<'a> TextureOut<'a> {
    /// A texture over `texels`, row-major.
    #[inline]
    pub fn new(texels: &'a mut [Texel]) -> Self {
        TextureOut {
            texels: Cell::from_mut(texels).as_slice_of_cells(),
        }
    }
}

impl Store for TextureOut<'_> {
    #[inline]
    fn store(&self, x: u32, y: u32, width: u32, value: Vec4) {
        self.texels[(y * width + x) as usize].set(value.to_array());
    }
}

impl Store for &TextureOut<'_> {
    #[inline]
    fn store(&self, x: u32, y: u32, width: u32, value: Vec4) {
        (**self).store(x, y, width, value)
    }
}

/// The SPIR-V type of an output texture binding: R32F (rust-gpu declares storage images
/// readable, which wgpu allows without a device feature for the 32-bit single-channel formats
/// only).
#[cfg(target_arch = "spirv")]
pub type StorageImage = spirv_std::Image!(2D, format = r32f, sampled = false);

#[cfg(target_arch = "spirv")]
impl Store for &StorageImage {
    #[inline]
    fn store(&self, x: u32, y: u32, _width: u32, value: Vec4) {
        // SAFETY: each invocation writes only the texels of its own pixels.
        unsafe { self.write(glam::UVec2::new(x, y), value.x) }
    }
}

/// Natively, where the shader crate's entry points are only type-checked, a CPU texture.
#[cfg(not(target_arch = "spirv"))]
pub type StorageImage = TextureOut<'static>;

/// How the CPU runner hands a texture binding's texels to a kernel: a read binding as a
/// [`Texture`], a written one as a [`TextureOut`].
pub trait IntoTexture {
    /// The kernel's argument.
    type Texture;
    /// Wraps the binding.
    fn into_texture(self) -> Self::Texture;
}

impl<'a> IntoTexture for &'a [Texel] {
    type Texture = Texture<'a>;
    fn into_texture(self) -> Texture<'a> {
        Texture::new(self)
    }
}

impl<'a> IntoTexture for &'a mut [Texel] {
    type Texture = TextureOut<'a>;
    fn into_texture(self) -> TextureOut<'a> {
        TextureOut::new(self)
    }
}
