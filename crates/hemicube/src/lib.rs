//! GPU hemi-cube vertex visibility (report §4, DESIGN.md §7) implementing
//! [`radiosity::Visibility`].
//!
//! Method `depth` (the default): the patches are rendered depth-only into the
//! five faces of a hemi-cube around the shooter point (the full top face and
//! four half side faces, one atlas texture), with reversed infinite-far depth
//! and a slope-scaled bias; a compute shader then tests every candidate
//! vertex against the depth at its pixel and the 3 × 3 pixels around it.
//! Vertices whose neighbourhood disagrees (a shadow edge within a pixel),
//! that fall on a face's border or on the horizon are *questionable* and are
//! ray cast on the CPU (§4.5), so the answers match the ray-cast reference
//! except where a hemi-cube pixel hides an occluder smaller than itself
//! entirely — the hemi-cube's inherent aliasing, which `--hemicube-res`
//! controls.
//!
//! The occluders are the patches: refinement splits elements inside their
//! patches without changing the geometry, so the vertex and index buffers are
//! uploaded once and never rebuilt; only the candidates travel per shot.

use glam::DVec3;
use gpu::{Gpu, GpuError, wgpu};
use libmesh::{Mesh, SurfaceId, VertId};
use radiosity::{RayVisibility, Visibility};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// The WGSL source.
pub const SHADER: &str = include_str!("hemicube.wgsl");

/// How visible vertices are found on the hemi-cube.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Method {
    /// Depth-only surface pass, then a compute test of every vertex.
    #[default]
    Depth,
}

/// Hemi-cube settings.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Pixels across the top face (a multiple of 64).
    pub res: u32,
    pub method: Method,
    /// Relative depth tolerance of the vertex test.
    pub depth_tolerance: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            res: 512,
            method: Method::Depth,
            depth_tolerance: 1e-4,
        }
    }
}

/// Counts for `-v` and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub shots: u64,
    pub candidates: u64,
    pub questionable: u64,
    /// Calls answered by ray casting because the GPU failed.
    pub fallbacks: u64,
}

#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct FaceU {
    right: [f32; 4],
    up: [f32; 4],
    fwd: [f32; 4],
    window: [f32; 4],
    viewport: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct ShotU {
    faces: [FaceU; 5],
    from: [f32; 4],
    params: [f32; 4],
}

struct Gpus {
    g: Gpu,
    vbuf: wgpu::Buffer,
    ibuf: wgpu::Buffer,
    n_indices: u32,
    shot_buf: wgpu::Buffer,
    face_buf: wgpu::Buffer,
    bind0: wgpu::BindGroup,
    bgl1: wgpu::BindGroupLayout,
    depth_pipeline: wgpu::RenderPipeline,
    test_pipeline: wgpu::ComputePipeline,
    depth_tex: wgpu::Texture,
    depth_view: wgpu::TextureView,
}

/// The hemi-cube visibility oracle.
pub struct Hemicube {
    gpu: Mutex<Gpus>,
    ray: RayVisibility,
    origin: DVec3,
    near: f64,
    opts: Options,
    shots: AtomicU64,
    candidates: AtomicU64,
    questionable: AtomicU64,
    fallbacks: AtomicU64,
    last_error: Mutex<Option<String>>,
}

const FACE_STRIDE: u64 = 256;

impl Hemicube {
    /// Uploads the patches of `mesh` and builds the pipelines.
    pub fn new(g: Gpu, mesh: &Mesh, opts: Options) -> Result<Hemicube, GpuError> {
        if opts.res < 64 || !opts.res.is_multiple_of(64) || opts.res > 8192 {
            return Err(GpuError(format!(
                "hemi-cube resolution {} is not a multiple of 64 in 64..8192",
                opts.res
            )));
        }
        let (w, h) = (opts.res, opts.res * 3);
        if h > g.limits.max_texture_dimension_2d {
            return Err(GpuError(format!(
                "hemi-cube resolution {} needs a {w}x{h} texture; this device allows {}",
                opts.res, g.limits.max_texture_dimension_2d
            )));
        }
        // The scene: patch corners relative to the box centre, in f32.
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in mesh.patches() {
            for &v in mesh.patch_corners(p) {
                let q = mesh.vertex_pos(v);
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        let origin = if lo.x.is_finite() {
            (lo + hi) * 0.5
        } else {
            DVec3::ZERO
        };
        let diag = if lo.x.is_finite() {
            (hi - lo).length().max(1e-9)
        } else {
            1.0
        };
        let mut verts: Vec<[f32; 4]> = Vec::new();
        let mut idx: Vec<u32> = Vec::new();
        for p in mesh.patches() {
            let c = mesh.patch_corners(p);
            let base = verts.len() as u32;
            for &v in c {
                verts.push(
                    (mesh.vertex_pos(v) - origin)
                        .as_vec3()
                        .extend(1.0)
                        .to_array(),
                );
            }
            for k in 1..c.len() as u32 - 1 {
                idx.extend([base, base + k, base + k + 1]);
            }
        }
        if verts.is_empty() {
            verts.push([0.0; 4]);
        }
        if idx.is_empty() {
            idx.extend([0, 0, 0]);
        }
        let module = g.shader("hemicube.wgsl", SHADER)?;
        let dev = &g.device;
        let vbuf = g.buffer_init(
            "hemicube vertices",
            bytemuck::cast_slice(&verts),
            wgpu::BufferUsages::VERTEX,
        );
        let ibuf = g.buffer_init(
            "hemicube indices",
            bytemuck::cast_slice(&idx),
            wgpu::BufferUsages::INDEX,
        );
        let shot_buf = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shot"),
            size: std::mem::size_of::<ShotU>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let face_data: Vec<u8> = (0..5u32)
            .flat_map(|k| {
                let mut b = vec![0u8; FACE_STRIDE as usize];
                b[..4].copy_from_slice(&k.to_le_bytes());
                b
            })
            .collect();
        let face_buf = g.buffer_init("face index", &face_data, wgpu::BufferUsages::UNIFORM);
        let uniform = |binding, dynamic| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: dynamic,
                min_binding_size: None,
            },
            count: None,
        };
        let bgl0 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hemicube shot"),
            entries: &[uniform(0, false), uniform(1, true)],
        });
        let bind0 = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hemicube shot"),
            layout: &bgl0,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: shot_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &face_buf,
                        offset: 0,
                        size: std::num::NonZeroU64::new(16),
                    }),
                },
            ],
        });
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let bgl1 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hemicube test"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                storage(1, true),
                storage(2, false),
            ],
        });
        let render_layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hemicube depth"),
            bind_group_layouts: &[Some(&bgl0)],
            immediate_size: 0,
        });
        let compute_layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hemicube test"),
            bind_group_layouts: &[Some(&bgl0), Some(&bgl1)],
            immediate_size: 0,
        });
        let attrs = wgpu::vertex_attr_array![0 => Float32x4];
        let depth_pipeline = dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("hemicube depth"),
            layout: Some(&render_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_depth"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 16,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attrs,
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                // Reversed depth: a negative slope-scaled bias pushes each
                // surface away, so that vertices on it pass the test.
                bias: wgpu::DepthBiasState {
                    constant: 0,
                    slope_scale: -2.0,
                    clamp: 0.0,
                },
            }),
            multisample: Default::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        let test_pipeline = dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("hemicube test"),
            layout: Some(&compute_layout),
            module: &module,
            entry_point: Some("cs_test"),
            compilation_options: Default::default(),
            cache: None,
        });
        let depth_tex = dev.create_texture(&wgpu::TextureDescriptor {
            label: Some("hemicube depth"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Depth32Float,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let depth_view = depth_tex.create_view(&Default::default());
        g.check()?;
        Ok(Hemicube {
            gpu: Mutex::new(Gpus {
                g,
                vbuf,
                ibuf,
                n_indices: idx.len() as u32,
                shot_buf,
                face_buf,
                bind0,
                bgl1,
                depth_pipeline,
                test_pipeline,
                depth_tex,
                depth_view,
            }),
            ray: RayVisibility::new(mesh),
            origin,
            near: diag * 1e-6,
            opts,
            shots: AtomicU64::new(0),
            candidates: AtomicU64::new(0),
            questionable: AtomicU64::new(0),
            fallbacks: AtomicU64::new(0),
            last_error: Mutex::new(None),
        })
    }

    /// What happened so far.
    pub fn stats(&self) -> Stats {
        Stats {
            shots: self.shots.load(Ordering::Relaxed),
            candidates: self.candidates.load(Ordering::Relaxed),
            questionable: self.questionable.load(Ordering::Relaxed),
            fallbacks: self.fallbacks.load(Ordering::Relaxed),
        }
    }

    /// The last GPU error (after which a call fell back to ray casting).
    pub fn last_error(&self) -> Option<String> {
        self.last_error.lock().ok().and_then(|e| e.clone())
    }

    /// The device's description.
    pub fn describe(&self) -> String {
        self.gpu.lock().map(|g| g.g.describe()).unwrap_or_default()
    }

    /// The five faces for a shooter point with normal n.
    fn shot_uniform(&self, from: DVec3, n: DVec3, count: usize) -> ShotU {
        let n = n.normalize();
        let a = if n.x.abs() < 0.6 { DVec3::X } else { DVec3::Y };
        let u = (a - n * a.dot(n)).normalize();
        let v = n.cross(u);
        let res = self.opts.res as f32;
        let v4 = |d: DVec3| d.as_vec3().extend(0.0).to_array();
        let mut faces = [FaceU::default(); 5];
        // Top: looking along n.
        faces[0] = FaceU {
            right: v4(u),
            up: v4(v),
            fwd: v4(n),
            window: [-1.0, 1.0, -1.0, 1.0],
            viewport: [0.0, 0.0, res, res],
        };
        // Sides: looking along ±u, ±v with n up; only the upper half.
        for (k, d) in [u, v, -u, -v].into_iter().enumerate() {
            faces[k + 1] = FaceU {
                right: v4(n.cross(d)),
                up: v4(n),
                fwd: v4(d),
                window: [-1.0, 1.0, 0.0, 1.0],
                viewport: [0.0, res + k as f32 * res / 2.0, res, res / 2.0],
            };
        }
        ShotU {
            faces,
            from: (from - self.origin)
                .as_vec3()
                .extend(self.near as f32)
                .to_array(),
            params: [count as f32, self.opts.depth_tolerance, 0.0, 0.0],
        }
    }

    /// Flags per candidate: 0 hidden, 1 visible, 2 questionable.
    fn gpu_flags(&self, from: DVec3, n: DVec3, rel: &[[f32; 4]]) -> Result<Vec<u32>, GpuError> {
        let s = self
            .gpu
            .lock()
            .map_err(|_| GpuError("hemi-cube state poisoned".into()))?;
        let g = &s.g;
        let mut out = Vec::with_capacity(rel.len());
        // Chunks keep each dispatch within the 65535 × 65535 workgroup grid
        // and the buffers within the device's binding size.
        let chunk = (g.limits.max_storage_buffer_binding_size as usize / 16).clamp(1, 1 << 22);
        let mut first = true;
        for part in rel.chunks(chunk) {
            let uni = self.shot_uniform(from, n, part.len());
            g.queue
                .write_buffer(&s.shot_buf, 0, bytemuck::bytes_of(&uni));
            let cand = g.buffer_init(
                "candidates",
                bytemuck::cast_slice(part),
                wgpu::BufferUsages::STORAGE,
            );
            let size = (part.len() * 4).max(4) as u64;
            let flags = g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("flags"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let bind1 = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("hemicube test"),
                layout: &s.bgl1,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&s.depth_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: cand.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: flags.as_entire_binding(),
                    },
                ],
            });
            let mut enc = g.device.create_command_encoder(&Default::default());
            if first {
                let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("hemicube depth"),
                    color_attachments: &[],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &s.depth_view,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(0.0),
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    ..Default::default()
                });
                rp.set_pipeline(&s.depth_pipeline);
                rp.set_vertex_buffer(0, s.vbuf.slice(..));
                rp.set_index_buffer(s.ibuf.slice(..), wgpu::IndexFormat::Uint32);
                for (k, f) in uni.faces.iter().enumerate() {
                    let [x, y, w, h] = f.viewport;
                    rp.set_viewport(x, y, w, h, 0.0, 1.0);
                    rp.set_scissor_rect(x as u32, y as u32, w as u32, h as u32);
                    rp.set_bind_group(0, &s.bind0, &[(k as u64 * FACE_STRIDE) as u32]);
                    rp.draw_indexed(0..s.n_indices, 0, 0..1);
                }
                first = false;
            }
            {
                let mut cp = enc.begin_compute_pass(&Default::default());
                cp.set_pipeline(&s.test_pipeline);
                cp.set_bind_group(0, &s.bind0, &[0]);
                cp.set_bind_group(1, &bind1, &[]);
                let groups = part.len().div_ceil(64) as u32;
                cp.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
            }
            g.queue.submit([enc.finish()]);
            let bytes = g.read_buffer(&flags, size)?;
            out.extend(
                bytes
                    .chunks_exact(4)
                    .take(part.len())
                    .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            );
        }
        let _ = &s.face_buf;
        let _ = &s.depth_tex;
        Ok(out)
    }
}

impl Visibility for Hemicube {
    fn visible(
        &self,
        mesh: &Mesh,
        from: DVec3,
        shooter: SurfaceId,
        candidates: &[VertId],
    ) -> Vec<bool> {
        self.shots.fetch_add(1, Ordering::Relaxed);
        self.candidates
            .fetch_add(candidates.len() as u64, Ordering::Relaxed);
        if candidates.is_empty() {
            return Vec::new();
        }
        let n = mesh.surface_normal(shooter);
        let rel: Vec<[f32; 4]> = candidates
            .iter()
            .map(|&v| (mesh.vertex_pos(v) - from).as_vec3().extend(0.0).to_array())
            .collect();
        let flags = match self.gpu_flags(from, n, &rel) {
            Ok(f) => f,
            Err(e) => {
                self.fallbacks.fetch_add(1, Ordering::Relaxed);
                if let Ok(mut le) = self.last_error.lock() {
                    *le = Some(e.0);
                }
                return self.ray.visible(mesh, from, shooter, candidates);
            }
        };
        // Ray cast the questionable vertices (§4.5).
        let q: Vec<VertId> = candidates
            .iter()
            .zip(&flags)
            .filter(|(_, f)| **f == 2)
            .map(|(v, _)| *v)
            .collect();
        self.questionable
            .fetch_add(q.len() as u64, Ordering::Relaxed);
        let mut rq = self.ray.visible(mesh, from, shooter, &q).into_iter();
        flags
            .iter()
            .map(|&f| match f {
                0 => false,
                1 => true,
                _ => rq.next().unwrap_or(false),
            })
            .collect()
    }

    fn name(&self) -> &'static str {
        "hemicube"
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn shader_validates_with_naga() {
        let m = gpu::validate_wgsl(super::SHADER).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
        assert!(
            names.contains(&"vs_depth") && names.contains(&"cs_test"),
            "{names:?}"
        );
    }
}
