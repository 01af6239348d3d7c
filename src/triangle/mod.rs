//! Triangles: 2D rasterization and mesh rendering.
//!
//! | file | what |
//! |---|---|
//! | `framebuffer` | [`Framebuffer<P>`], [`RenderTarget`] (colour + depth), PNG output |
//! | `raster` | edge functions (Pineda 1988), incremental, exact `i64`, top-left rule |
//! | `scanline` | exact scanline spans (Petridis; classic active-edge filling) |
//! | `interp` | barycentric interpolation, flat / Gouraud shading, painter's order, z-buffer |
//! | `inside` | batched point-in-triangle tests (qTriangle cross-product form), auto-vectorized |
//! | `camera` | [`Camera`] (perspective / orthographic), shared with the ray caster |
//! | `render_mesh` | [`render_mesh`]: 3D mesh → clipped, z-buffered, Gouraud-shaded image |
//!
//! Screen conventions (all rasterizers): y down, pixel `(x, y)` sampled at
//! its centre `(x + ½, y + ½)`, vertices in sub-pixel fixed point with
//! [`SUB_BITS`] = 8 fraction bits and `|v| ≤ 2^20` pixels, **top-left fill
//! rule**, zero-area triangles cover nothing. The edge-function and scanline
//! rasterizers produce the same pixels (tested on thousands of random and
//! degenerate triangles).

mod camera;
mod framebuffer;
mod inside;
mod interp;
pub mod raster;
mod render_mesh;
pub mod scanline;

pub use camera::{Camera, Projection};
pub use framebuffer::{Framebuffer, MAX_DIM, PngPixel, RenderTarget, Rgb8, Rgba8};
pub use inside::{CHUNK, INSIDE_I32_MAX, InsideF32, InsideI32};
pub use interp::{
    DepthTest, Interpolator, ShadedVertex, Shading, barycentric, draw_painter, draw_shaded,
    draw_zbuffer, interpolate, painter_order, to_rgb8,
};
pub use raster::{
    EdgeEq, FixedTriangle, Fragment, Fragments, MAX_FIXED_COORD, MAX_PIXEL_COORD, PixelRect,
    SUB_BITS, SUB_HALF, SUB_ONE, TriangleSetup, edge_spans, fill_triangle_edge, to_subpixel,
    walk_fragments,
};
pub use render_mesh::{Lighting, MeshRenderOptions, render_mesh, render_mesh_png, vertex_normals};
pub use scanline::{fill_triangle_scanline, scanline_spans};
