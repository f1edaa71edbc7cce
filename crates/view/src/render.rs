//! Rasterising a [`Scene`] on wgpu into an [`Hdr`] picture.

use crate::camera::Camera;
use crate::scene::{GpuVertex, Scene};
use crate::tone::Hdr;
use glam::DVec3;
use gpu::{Gpu, GpuError, wgpu};

/// The WGSL source of the surface and line shaders.
pub const SHADER: &str = include_str!("view.wgsl");

/// What to draw and how.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (1 or 4).
    pub msaa: u32,
    /// Draw back faces magenta instead of culling them.
    pub backfaces: bool,
    /// Overlay the face (element) edges.
    pub mesh: bool,
    /// Discard everything on the positive side of this plane (unit normal n,
    /// offset d: points with n·p > d), in model coordinates.
    pub cut: Option<(DVec3, f64)>,
    /// Linear RGB of mesh lines and their opacity.
    pub line_colour: [f32; 4],
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 800,
            height: 600,
            msaa: 4,
            backfaces: false,
            mesh: false,
            cut: None,
            line_colour: [0.02, 0.02, 0.02, 0.85],
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Uniforms {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    cut: [f32; 4],
    params: [f32; 4],
    line_colour: [f32; 4],
}

const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const OVERLAY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Renders the scene; returns radiance (lit) or display colour (unlit) per pixel.
pub fn render(g: &Gpu, scene: &Scene, cam: &Camera, o: &RenderOptions) -> Result<Hdr, GpuError> {
    let (w, h) = (o.width, o.height);
    let max_dim = g.limits.max_texture_dimension_2d;
    if w == 0 || h == 0 || w > max_dim || h > max_dim {
        return Err(GpuError(format!(
            "picture size {w}x{h} is outside 1..{max_dim} on this device"
        )));
    }
    let n = (w * h) as usize;
    let Some(bounds) = scene.bounds else {
        return Ok(Hdr {
            width: w,
            height: h,
            rgb: vec![[0.0; 3]; n],
            coverage: vec![0.0; n],
            overlay: vec![[0.0; 4]; n],
        });
    };
    let aspect = f64::from(w) / f64::from(h);
    let vp = cam.view_proj(&bounds, aspect, scene.origin).as_mat4();
    let eye = match cam.ortho_half_height {
        Some(_) => (cam.look - cam.eye).normalize().as_vec3().extend(1.0),
        None => (cam.eye - scene.origin).as_vec3().extend(0.0),
    };
    // Half floats reach 65504: scale colours so that the largest is 1.
    let scale = if scene.max_colour > 0.0 {
        1.0 / scene.max_colour
    } else {
        1.0
    };
    let cut = match o.cut {
        Some((nrm, d)) => {
            let nrm = nrm.normalize();
            // In scene coordinates (relative to the origin).
            let d = d - nrm.dot(scene.origin);
            [nrm.x as f32, nrm.y as f32, nrm.z as f32, d as f32]
        }
        None => [0.0; 4],
    };
    let uniforms = Uniforms {
        view_proj: vp.to_cols_array_2d(),
        eye: eye.to_array(),
        cut,
        params: [scale, if scene.lit { 1.0 } else { 0.0 }, 0.0, 2e-4],
        line_colour: {
            let c = o.line_colour;
            [c[0] * c[3], c[1] * c[3], c[2] * c[3], c[3]]
        },
    };

    let dev = &g.device;
    let module = g.shader("view.wgsl", SHADER)?;
    let ubuf = g.buffer_init(
        "uniforms",
        bytemuck::bytes_of(&uniforms),
        wgpu::BufferUsages::UNIFORM,
    );
    let bgl = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("view"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    });
    let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("view"),
        layout: &bgl,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: ubuf.as_entire_binding(),
        }],
    });
    let layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("view"),
        bind_group_layouts: &[Some(&bgl)],
        immediate_size: 0,
    });
    let attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3];
    let vlayout = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &attrs,
    };
    let pipe = |label, vertex, fragment, primitive, depth| {
        g.render_pipeline(gpu::Pipeline {
            label,
            layout: &layout,
            module: &module,
            vertex,
            buffer: vlayout.clone(),
            fragment: Some(fragment),
            primitive,
            depth,
            samples: o.msaa,
        })
    };
    let surface_targets = [
        gpu::target(HDR_FORMAT, true),
        gpu::target(OVERLAY_FORMAT, true),
    ];
    let surface = pipe(
        "surfaces",
        "vs_surface",
        ("fs_surface", &surface_targets),
        wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: if o.backfaces {
                None
            } else {
                Some(wgpu::Face::Back)
            },
            ..Default::default()
        },
        gpu::depth_test(
            DEPTH_FORMAT,
            true,
            wgpu::CompareFunction::Less,
            Default::default(),
        ),
    );
    // Lines leave the HDR target alone and draw into the overlay.
    let line_targets = [
        gpu::target(HDR_FORMAT, false),
        gpu::target(OVERLAY_FORMAT, true),
    ];
    let lines = pipe(
        "mesh lines",
        "vs_line",
        ("fs_line", &line_targets),
        wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::LineList,
            ..Default::default()
        },
        gpu::depth_test(
            DEPTH_FORMAT,
            false,
            wgpu::CompareFunction::LessEqual,
            Default::default(),
        ),
    );
    g.check()?;

    let tex =
        |label: &str, format, samples, usage| g.texture_2d(label, (w, h), format, samples, usage);
    let ra = wgpu::TextureUsages::RENDER_ATTACHMENT;
    let out_usage = ra | wgpu::TextureUsages::COPY_SRC;
    let hdr_out = tex("hdr", HDR_FORMAT, 1, out_usage);
    let ov_out = tex("overlay", OVERLAY_FORMAT, 1, out_usage);
    let (hdr_ms, ov_ms) = if o.msaa > 1 {
        (
            Some(tex("hdr msaa", HDR_FORMAT, o.msaa, ra)),
            Some(tex("overlay msaa", OVERLAY_FORMAT, o.msaa, ra)),
        )
    } else {
        (None, None)
    };
    let depth = tex("depth", DEPTH_FORMAT, o.msaa, ra);
    let view = |t: &wgpu::Texture| t.create_view(&Default::default());
    let (hdr_v, ov_v, depth_v) = (view(&hdr_out), view(&ov_out), view(&depth));
    let hdr_ms_v = hdr_ms.as_ref().map(view);
    let ov_ms_v = ov_ms.as_ref().map(view);

    let vbuf = g.buffer_init(
        "vertices",
        bytemuck::cast_slice(&scene.vertices),
        wgpu::BufferUsages::VERTEX,
    );
    let tbuf = g.buffer_init(
        "triangles",
        bytemuck::cast_slice(&scene.triangles),
        wgpu::BufferUsages::INDEX,
    );
    let lbuf = g.buffer_init(
        "lines",
        bytemuck::cast_slice(&scene.lines),
        wgpu::BufferUsages::INDEX,
    );
    g.check()?;

    let mut enc = dev.create_command_encoder(&Default::default());
    for pass in 0..2 {
        if pass == 1 && (!o.mesh || scene.lines.is_empty()) {
            break;
        }
        // Pass 0 draws surfaces; pass 1 adds lines, keeping colour and depth.
        let first = pass == 0;
        let last = pass == 1 || !o.mesh || scene.lines.is_empty();
        // Multisampled targets resolve into the single-sample ones on the last pass.
        let target = |ms: &Option<wgpu::TextureView>, single: &wgpu::TextureView| {
            (
                ms.clone().unwrap_or_else(|| single.clone()),
                ms.as_ref().map(|_| single.clone()),
            )
        };
        let (a, a_res) = target(&hdr_ms_v, &hdr_v);
        let (b, b_res) = target(&ov_ms_v, &ov_v);
        let clear = first.then_some(wgpu::Color::TRANSPARENT);
        let resolve = |r: &Option<wgpu::TextureView>| if last { r.clone() } else { None };
        let (a_res, b_res) = (resolve(&a_res), resolve(&b_res));
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(if first { "surfaces" } else { "lines" }),
            color_attachments: &[
                gpu::color_target(&a, a_res.as_ref(), clear),
                gpu::color_target(&b, b_res.as_ref(), clear),
            ],
            depth_stencil_attachment: gpu::depth_target(&depth_v, first.then_some(1.0)),
            ..Default::default()
        });
        rp.set_bind_group(0, &bind, &[]);
        rp.set_vertex_buffer(0, vbuf.slice(..));
        if first {
            if !scene.triangles.is_empty() {
                rp.set_pipeline(&surface);
                rp.set_index_buffer(tbuf.slice(..), wgpu::IndexFormat::Uint32);
                rp.draw_indexed(0..scene.triangles.len() as u32, 0, 0..1);
            }
        } else {
            rp.set_pipeline(&lines);
            rp.set_index_buffer(lbuf.slice(..), wgpu::IndexFormat::Uint32);
            rp.draw_indexed(0..scene.lines.len() as u32, 0, 0..1);
        }
    }
    g.queue.submit([enc.finish()]);
    g.wait()?;
    let hdr_px = g.read_texture(&hdr_out, 8)?;
    let ov_px = g.read_texture(&ov_out, 8)?;
    let half4 = |b: &[u8]| -> [f32; 4] {
        [0, 1, 2, 3].map(|k| half::f16::from_le_bytes([b[2 * k], b[2 * k + 1]]).to_f32())
    };
    let inv = 1.0 / scale;
    let mut rgb = Vec::with_capacity(n);
    let mut coverage = Vec::with_capacity(n);
    for p in hdr_px.chunks_exact(8) {
        let v = half4(p);
        rgb.push([v[0] * inv, v[1] * inv, v[2] * inv]);
        coverage.push(v[3]);
    }
    let overlay = ov_px.chunks_exact(8).map(half4).collect();
    Ok(Hdr {
        width: w,
        height: h,
        rgb,
        coverage,
        overlay,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn shader_validates_with_naga() {
        let m = gpu::validate_wgsl(super::SHADER).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
        for want in ["vs_surface", "fs_surface", "vs_line", "fs_line"] {
            assert!(names.contains(&want), "{names:?}");
        }
    }
}
