//! Host side of the `bpm_render` pipeline (`shaders/bpm_render.wgsl`): a textured picture whose
//! per-pixel UV is the BPM (or linear) interpolant. Twin of the reference's
//! `bpm::render::render_cpu`.

use bytemuck::{Pod, Zeroable};

use super::{shader_source, Interp, TriangleMaps, BPM_COMMON_WGSL};
use crate::{Gpu, GpuError};

/// The pipeline's own WGSL (after `bpm_common.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/bpm_render.wgsl");

const COLOUR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// What to draw and how.
#[derive(Clone, Copy, Debug)]
pub struct RenderInput<'a> {
    /// Picture size in pixels.
    pub width: u32,
    pub height: u32,
    /// World → wgpu clip space (depth 0..1, NDC y up), column-major.
    pub view_proj: [f32; 16],
    /// Triangle corners, 3 per face, non-indexed (face f = corners 3f, 3f + 1, 3f + 2; xyz used).
    pub corners: &'a [[f32; 4]],
    /// Per-face BPM data (at least one per face), e.g. from `bpm_precompute::run`.
    pub maps: &'a [TriangleMaps],
    /// Texture size and its RGBA8 bytes, rows top first (`4 · width · height` bytes).
    pub texture_width: u32,
    pub texture_height: u32,
    pub texture: &'a [u8],
    pub interp: Interp,
    /// Colour where no face is drawn.
    pub background: [u8; 4],
}

/// Uniform of the pipeline (80 bytes; WGSL `RenderParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct RenderParams {
    view_proj: [f32; 16],
    interp: u32,
    _pad: [u32; 3],
}

/// Render the faces into a `width × height` RGBA8 picture, tightly packed, top row first.
///
/// Per pixel centre: the nearest face (Depth32Float z-buffer, `Less`, cleared to 1; no culling),
/// its perspective-correct barycentrics b, uv = eval(face, b) (as in `bpm_eval`), and
/// colour = bilinear(texture, (u, 1 − v)) with REPEAT addressing on raw Rgba8Unorm values
/// (texel centres at (x + ½)/W), no mipmaps, no lighting; `background` elsewhere.
pub fn run(gpu: &Gpu, input: &RenderInput) -> Result<Vec<u8>, GpuError> {
    run_windowed(
        gpu,
        input,
        gpu.max_chunk_len(std::mem::size_of::<TriangleMaps>()),
    )
}

/// [`run`] drawing at most `faces_per_window` faces per draw call (each window has its own
/// corner and map buffers, so meshes larger than one storage binding render too; all windows
/// share the pass and its z-buffer).
pub fn run_windowed(
    gpu: &Gpu,
    input: &RenderInput,
    faces_per_window: usize,
) -> Result<Vec<u8>, GpuError> {
    check_input(gpu, input)?;
    let (staging, submission) = gpu.checked(|| {
        let colour = target_texture(gpu, input, COLOUR_FORMAT, wgpu::TextureUsages::COPY_SRC);
        let depth = target_texture(gpu, input, DEPTH_FORMAT, wgpu::TextureUsages::empty());
        let pipeline = gpu.cached("bpm_render pipeline", || Ok(render_pipeline(gpu)))?;
        let windows = bind_groups(gpu, &pipeline, input, faces_per_window.max(1))?;
        let mut encoder = gpu.encoder("bpm_render");
        draw(
            &mut encoder,
            &pipeline,
            &windows,
            &colour,
            &depth,
            input.background,
        );
        let staging = copy_to_staging(gpu, &mut encoder, &colour, input);
        Ok((staging, gpu.submit(encoder.finish())))
    })?;
    let bytes = gpu.map_staging(&staging, submission)?;
    Ok(strip_row_padding(
        &bytes,
        4 * input.width as usize,
        padded_bytes_per_row(input.width) as usize,
    ))
}

/// [`GpuError::Input`] for inconsistent sizes, [`GpuError::ExceedsLimit`] beyond the device's
/// texture size or (for the readback of the picture) buffer size.
fn check_input(gpu: &Gpu, input: &RenderInput) -> Result<(), GpuError> {
    let max = gpu.limits().max_texture_dimension_2d;
    for (what, w, h) in [
        ("picture", input.width, input.height),
        ("texture", input.texture_width, input.texture_height),
    ] {
        if w == 0 || h == 0 {
            return Err(GpuError::Input(format!("empty {what} ({w}×{h})")));
        }
        if w > max || h > max {
            return Err(GpuError::ExceedsLimit {
                kernel: format!("bpm_render {what}"),
                limit: "max_texture_dimension_2d",
                needed: u64::from(w.max(h)),
                allowed: u64::from(max),
            });
        }
    }
    gpu.check_buffer_size(
        "bpm_render readback",
        u64::from(padded_bytes_per_row(input.width)) * u64::from(input.height),
    )?;
    let texture_bytes = 4 * input.texture_width as usize * input.texture_height as usize;
    if input.texture.len() != texture_bytes {
        return Err(GpuError::Input(format!(
            "texture has {} bytes, {}×{} RGBA8 needs {texture_bytes}",
            input.texture.len(),
            input.texture_width,
            input.texture_height
        )));
    }
    if !input.corners.len().is_multiple_of(3) || input.maps.len() < input.corners.len() / 3 {
        return Err(GpuError::Input(format!(
            "{} corners (3 per face) for {} faces' maps",
            input.corners.len(),
            input.maps.len()
        )));
    }
    Ok(())
}

/// A picture-sized 2D render attachment of `format` with `usage` added.
fn target_texture(
    gpu: &Gpu,
    input: &RenderInput,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("bpm_render target"),
        size: extent(input.width, input.height),
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | usage,
        view_formats: &[],
    })
}

fn extent(width: u32, height: u32) -> wgpu::Extent3d {
    wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    }
}

/// The input texture as Rgba8Unorm (raw byte values, no sRGB decoding), rows top first.
fn upload_texture(gpu: &Gpu, input: &RenderInput) -> wgpu::Texture {
    let size = extent(input.texture_width, input.texture_height);
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("bpm_render texture"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: COLOUR_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    gpu.queue.write_texture(
        texture.as_image_copy(),
        input.texture,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(4 * input.texture_width),
            rows_per_image: Some(input.texture_height),
        },
        size,
    );
    texture
}

/// Bilinear filtering with REPEAT addressing, no mipmaps.
fn uv_sampler(gpu: &Gpu) -> wgpu::Sampler {
    gpu.device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("bpm_render sampler"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        address_mode_w: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Nearest,
        ..Default::default()
    })
}

/// Vertex pulling from the corner buffer, `eval` + texture in the fragment shader, z-buffer
/// with `Less`, no culling, no blending; bind group layout inferred from the shader. Made once
/// per context ([`Gpu::cached`]).
fn render_pipeline(gpu: &Gpu) -> wgpu::RenderPipeline {
    let module = gpu
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("bpm_render"),
            source: wgpu::ShaderSource::Wgsl(shader_source(&[BPM_COMMON_WGSL, WGSL]).into()),
        });
    gpu.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("bpm_render"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("bpm_render_vertex"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("bpm_render_fragment"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: COLOUR_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
}

/// A bind group (bindings 0–4: params, corners, maps, texture, sampler) and its vertex count
/// for each window of `faces_per_window` faces; params, texture and sampler are shared.
fn bind_groups(
    gpu: &Gpu,
    pipeline: &wgpu::RenderPipeline,
    input: &RenderInput,
    faces_per_window: usize,
) -> Result<Vec<(wgpu::BindGroup, u32)>, GpuError> {
    let params = gpu.upload_uniform(
        "bpm_render params",
        &RenderParams {
            view_proj: input.view_proj,
            interp: input.interp.code(),
            _pad: [0; 3],
        },
    );
    let texture = upload_texture(gpu, input).create_view(&Default::default());
    let sampler = uv_sampler(gpu);
    let layout = pipeline.get_bind_group_layout(0);
    let faces = input.corners.len() / 3;
    // At least one (empty) window, so that the background is drawn for an empty mesh.
    let starts: Vec<usize> = (0..faces.max(1)).step_by(faces_per_window).collect();
    starts
        .into_iter()
        .map(|start| {
            let end = (start + faces_per_window).min(faces);
            let corners =
                gpu.upload_storage("bpm_render corners", &input.corners[3 * start..3 * end])?;
            let maps = gpu.upload_storage("bpm_render maps", &input.maps[start..end])?;
            let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("bpm_render"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: corners.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: maps.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::TextureView(&texture),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: wgpu::BindingResource::Sampler(&sampler),
                    },
                ],
            });
            Ok((group, 3 * (end - start) as u32))
        })
        .collect()
}

/// One render pass: clear colour to the background and depth to 1, then one draw per window.
fn draw(
    encoder: &mut wgpu::CommandEncoder,
    pipeline: &wgpu::RenderPipeline,
    windows: &[(wgpu::BindGroup, u32)],
    colour: &wgpu::Texture,
    depth: &wgpu::Texture,
    background: [u8; 4],
) {
    let colour_view = colour.create_view(&Default::default());
    let depth_view = depth.create_view(&Default::default());
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("bpm_render"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: &colour_view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(background_colour(background)),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: &depth_view,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        ..Default::default()
    });
    pass.set_pipeline(pipeline);
    for (group, vertices) in windows {
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..*vertices, 0..1);
    }
}

/// The background as a clear colour: byte / 255 (stored back exactly by Rgba8Unorm).
fn background_colour(rgba: [u8; 4]) -> wgpu::Color {
    let [r, g, b, a] = rgba.map(|x| x as f64 / 255.0);
    wgpu::Color { r, g, b, a }
}

/// Bytes per row of a texture-to-buffer copy: 4 · width rounded up to
/// `COPY_BYTES_PER_ROW_ALIGNMENT` (256).
fn padded_bytes_per_row(width: u32) -> u32 {
    (4 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
}

/// Copy the colour target into a new mappable buffer, rows padded to [`padded_bytes_per_row`].
fn copy_to_staging(
    gpu: &Gpu,
    encoder: &mut wgpu::CommandEncoder,
    colour: &wgpu::Texture,
    input: &RenderInput,
) -> wgpu::Buffer {
    let bytes_per_row = padded_bytes_per_row(input.width);
    let staging = gpu.staging_buffer(
        "bpm_render readback",
        bytes_per_row as u64 * input.height as u64,
    );
    encoder.copy_texture_to_buffer(
        colour.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(bytes_per_row),
                rows_per_image: Some(input.height),
            },
        },
        extent(input.width, input.height),
    );
    staging
}

/// The first `row_bytes` of every `padded_row`-byte row, concatenated.
fn strip_row_padding(bytes: &[u8], row_bytes: usize, padded_row: usize) -> Vec<u8> {
    bytes
        .chunks(padded_row)
        .flat_map(|row| &row[..row_bytes])
        .copied()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_padded_to_256_bytes_and_stripped() {
        assert_eq!(padded_bytes_per_row(1), 256);
        assert_eq!(padded_bytes_per_row(64), 256);
        assert_eq!(padded_bytes_per_row(65), 512);
        let padded: Vec<u8> = (0..2)
            .flat_map(|r| (0..8).map(move |x| (10 * r + x) as u8))
            .collect();
        assert_eq!(strip_row_padding(&padded, 3, 8), vec![0, 1, 2, 10, 11, 12]);
    }

    #[test]
    fn render_params_match_the_wgsl_uniform() {
        assert_eq!(std::mem::size_of::<RenderParams>(), 80);
    }
}
