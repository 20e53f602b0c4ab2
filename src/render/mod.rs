//! Rendering: the scene as a triangle soup with per-triangle attributes (`scene`), the camera
//! model (`camera`), frames and the images derived from them (`frame`; images a renderer derived itself, `derived`; the
//! label taxonomies are the scene's, `scene::Taxonomy`), the images sensors produce (`image`), textures (`texture`, `texture_library`), and two renderers producing the same frames, chosen in `renderer`: the CPU rasteriser (`cpu`, always
//! available) and wgpu (`gpu`, when an adapter exists).

internal! {
    pub mod bvh;
}
mod camera;
internal! {
    pub mod cpu;
}
internal! {
    pub mod derived;
}
mod frame;
pub mod gpu;
mod image;
internal! {
    pub mod raycast;
}
mod renderer;
internal! {
    pub mod scene;
}
pub mod texture;
pub mod texture_library;
pub mod visualize;

pub use camera::Camera;
pub use derived::{Channel, Channels, Derived};
pub use frame::{Frame, NO_HIT};
pub use image::{Image, Modality, PixelType};
pub use renderer::{Renderer, RendererChoice};
pub use scene::{Cluster, RenderScene, TriInfo, UvMap, NO_ID, NO_TEXTURE};
