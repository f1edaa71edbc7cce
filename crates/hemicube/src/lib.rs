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
pub const SHADER: &str = concat!(include_str!("common.wgsl"), include_str!("hemicube.wgsl"));

/// How visible vertices are found on the hemi-cube.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Method {
    /// Depth-only surface pass, then a compute test of every vertex against
    /// the depth at its pixel and the 3 × 3 around it.
    #[default]
    Depth,
    /// Depth-only surface pass, then the vertices as points with the depth
    /// test on, each surviving fragment marking its vertex in a storage
    /// buffer (needs the native feature SHADER_EARLY_DEPTH_TEST).
    Points,
    /// The report's decal algorithm (§4.3–4.4): per surface a colour pass,
    /// its vertices as id points, a depth pass; the id image read back and
    /// redrawn with the vertices not yet seen until no new one appears.
    Decal,
}

impl Method {
    pub fn parse(s: &str) -> Option<Method> {
        match s {
            "depth" => Some(Method::Depth),
            "points" => Some(Method::Points),
            "decal" => Some(Method::Decal),
            _ => None,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Method::Depth => "depth",
            Method::Points => "points",
            Method::Decal => "decal",
        }
    }
}

/// The GPU's answer for each candidate before the questionable ones are ray
/// cast: `raw` is what the hemi-cube saw, `questionable` marks those the
/// CPU ray casts (§4.5).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Classified {
    pub raw: Vec<bool>,
    pub questionable: Vec<bool>,
}

/// The points method needs this feature of the adapter.
pub const POINTS_FEATURE: wgpu::Features = wgpu::Features::SHADER_EARLY_DEPTH_TEST;

/// Source of the points method's shader.
pub const POINTS_SHADER: &str = concat!(include_str!("common.wgsl"), include_str!("points.wgsl"));
/// Source of the decal method's shader.
pub const DECAL_SHADER: &str = concat!(include_str!("common.wgsl"), include_str!("decal.wgsl"));

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

struct PointsPipes {
    pipeline: wgpu::RenderPipeline,
    bgl: wgpu::BindGroupLayout,
}

struct DecalPipes {
    surface: wgpu::RenderPipeline,
    points: wgpu::RenderPipeline,
    depth: wgpu::RenderPipeline,
    id_tex: wgpu::Texture,
    id_view: wgpu::TextureView,
}

struct Gpus {
    g: Gpu,
    vbuf: wgpu::Buffer,
    ibuf: wgpu::Buffer,
    n_indices: u32,
    /// Index ranges (start, count) of each surface's triangles, in surface order.
    surface_ranges: Vec<(u32, u32)>,
    shot_buf: wgpu::Buffer,
    _face_buf: wgpu::Buffer,
    bind0: wgpu::BindGroup,
    bgl1: wgpu::BindGroupLayout,
    depth_pipeline: wgpu::RenderPipeline,
    id_pipeline: wgpu::RenderPipeline,
    test_pipeline: wgpu::ComputePipeline,
    _surface_ids: wgpu::Texture,
    surface_ids_view: wgpu::TextureView,
    normal_buf: wgpu::Buffer,
    _depth_tex: wgpu::Texture,
    depth_view: wgpu::TextureView,
    points: Option<PointsPipes>,
    decal: Option<DecalPipes>,
}

/// How visibility is chosen (`ugrad --visibility`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Choice {
    /// The hemi-cube on a hardware GPU, else ray casting (on a software
    /// rasteriser such as lavapipe the CPU ray caster is faster).
    Auto,
    /// CPU ray casting (the reference).
    Ray,
    /// The hemi-cube on whatever adapter there is; an error without one.
    Hemicube,
}

/// What [`choose`] decided: the hemi-cube (`None`: ray casting), a line for
/// `-v` and a note for stderr (shown unless `-q`).
pub struct Chosen {
    pub hemicube: Option<Hemicube>,
    pub detail: Option<String>,
    pub note: Option<String>,
}

/// Opens the GPU and builds the hemi-cube as `choice` asks. Only
/// [`Choice::Hemicube`] fails (no adapter, or the hemi-cube cannot be
/// built on it); `Auto` falls back to ray casting with a note.
pub fn choose(
    choice: Choice,
    mesh: &Mesh,
    request: &gpu::Request,
    opts: Options,
) -> Result<Chosen, String> {
    let ray = |detail: Option<String>, note: Option<String>| Chosen {
        hemicube: None,
        detail,
        note,
    };
    match choice {
        Choice::Ray => Ok(ray(None, None)),
        Choice::Hemicube => {
            let g = gpu::open(request).map_err(|e| format!("--visibility hemicube: {e}"))?;
            let detail = format!(
                "visibility: hemi-cube ({}, {}²) on {}",
                opts.method.name(),
                opts.res,
                g.describe()
            );
            let h =
                Hemicube::new(g, mesh, opts).map_err(|e| format!("--visibility hemicube: {e}"))?;
            Ok(Chosen {
                hemicube: Some(h),
                detail: Some(detail),
                note: None,
            })
        }
        Choice::Auto => match gpu::open(request) {
            Ok(g) if !g.is_cpu() => match Hemicube::new(g, mesh, opts) {
                Ok(h) => {
                    let detail = format!(
                        "visibility: hemi-cube ({}, {}²) on {}, a hardware GPU (faster than CPU rays)",
                        opts.method.name(),
                        opts.res,
                        h.describe()
                    );
                    Ok(Chosen {
                        hemicube: Some(h),
                        detail: Some(detail),
                        note: None,
                    })
                }
                Err(e) => Ok(ray(
                    None,
                    Some(format!(
                        "note: hemi-cube unavailable ({e}); visibility by CPU ray casting"
                    )),
                )),
            },
            Ok(g) => Ok(ray(
                Some(format!(
                    "note: visibility by CPU ray casting (the only GPU adapter, {}, is a software rasteriser; --visibility hemicube uses it anyway)",
                    g.describe()
                )),
                None,
            )),
            Err(e) => Ok(ray(
                None,
                Some(format!(
                    "note: no GPU for the hemi-cube ({e}); visibility by CPU ray casting"
                )),
            )),
        },
    }
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
/// Another surface nearer than a vertex by less than this relative depth
/// leaves the vertex uncertain (ray cast) rather than hidden.
const UNCERTAIN: f32 = 1e-3;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

/// Reversed depth: a negative slope-scaled bias pushes each surface away, so
/// that vertices on it pass the test.
const SURFACE_BIAS: wgpu::DepthBiasState = wgpu::DepthBiasState {
    constant: 0,
    slope_scale: -2.0,
    clamp: 0.0,
};

fn depth_state(
    write: bool,
    compare: wgpu::CompareFunction,
    bias: wgpu::DepthBiasState,
) -> Option<wgpu::DepthStencilState> {
    gpu::depth_test(DEPTH_FORMAT, write, compare, bias)
}

impl Hemicube {
    /// Uploads the patches of `mesh` and builds the pipelines of `opts.method`.
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
        if opts.method == Method::Points && !g.features.contains(POINTS_FEATURE) {
            return Err(GpuError(format!(
                "the points method needs the feature SHADER_EARLY_DEPTH_TEST, which {} lacks",
                g.describe()
            )));
        }
        // The scene: patch corners relative to the box centre, in f32, the
        // triangles grouped by surface.
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
        let mut surface_ranges = Vec::with_capacity(mesh.num_surfaces());
        for s in mesh.surfaces() {
            let start = idx.len() as u32;
            for &p in mesh.surface_patches(s) {
                let c = mesh.patch_corners(p);
                let base = verts.len() as u32;
                for &v in c {
                    let q = (mesh.vertex_pos(v) - origin).as_vec3();
                    verts.push([q.x, q.y, q.z, f32::from_bits(s.0)]);
                }
                for k in 1..c.len() as u32 - 1 {
                    idx.extend([base, base + k, base + k + 1]);
                }
            }
            surface_ranges.push((start, idx.len() as u32 - start));
        }
        let n_indices = idx.len() as u32;
        let mut normals: Vec<[f32; 4]> = mesh
            .surfaces()
            .map(|s| {
                mesh.surface_normal(s)
                    .normalize()
                    .as_vec3()
                    .extend(0.0)
                    .to_array()
            })
            .collect();
        if normals.is_empty() {
            normals.push([0.0; 4]);
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
        let normal_buf = g.buffer_init(
            "surface normals",
            bytemuck::cast_slice(&normals),
            wgpu::BufferUsages::STORAGE,
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
        let storage = |binding, read_only, stage| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: stage,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let cs = wgpu::ShaderStages::COMPUTE;
        let bgl1 = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hemicube test"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: cs,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                storage(1, true, cs),
                storage(2, false, cs),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: cs,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Uint,
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                storage(4, true, cs),
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
        let vlayout = wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &attrs,
        };
        let tri = wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        };
        let pts = wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::PointList,
            ..Default::default()
        };
        let pipe = |label, module, vertex, fragment, primitive, depth| {
            g.render_pipeline(gpu::Pipeline {
                label,
                layout: &render_layout,
                module,
                vertex,
                buffer: vlayout.clone(),
                fragment,
                primitive,
                depth,
                samples: 1,
            })
        };
        let depth_pipeline = pipe(
            "hemicube depth",
            &module,
            "vs_depth",
            None,
            tri,
            depth_state(true, wgpu::CompareFunction::Greater, SURFACE_BIAS),
        );
        let id_target = [gpu::target(ID_FORMAT, true)];
        let id_pipeline = pipe(
            "hemicube surface ids",
            &module,
            "vs_depth",
            Some(("fs_id", &id_target)),
            tri,
            depth_state(true, wgpu::CompareFunction::Greater, Default::default()),
        );
        let test_pipeline = dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("hemicube test"),
            layout: Some(&compute_layout),
            module: &module,
            entry_point: Some("cs_test"),
            compilation_options: Default::default(),
            cache: None,
        });
        let tex = |label, format, usage| g.texture_2d(label, (w, h), format, 1, usage);
        let depth_tex = tex(
            "hemicube depth",
            DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let depth_view = depth_tex.create_view(&Default::default());
        let surface_ids = tex(
            "hemicube surface ids",
            ID_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let surface_ids_view = surface_ids.create_view(&Default::default());
        let points = if opts.method == Method::Points {
            let pmod = g.shader("points.wgsl", POINTS_SHADER)?;
            let fs = wgpu::ShaderStages::FRAGMENT;
            let bgl = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("hemicube points"),
                entries: &[storage(0, false, fs)],
            });
            let layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("hemicube points"),
                bind_group_layouts: &[Some(&bgl0), Some(&bgl)],
                immediate_size: 0,
            });
            let pipeline = g.render_pipeline(gpu::Pipeline {
                label: "hemicube points",
                layout: &layout,
                module: &pmod,
                vertex: "vs_point",
                buffer: vlayout.clone(),
                fragment: Some(("fs_point", &[])),
                primitive: pts,
                depth: depth_state(
                    false,
                    wgpu::CompareFunction::GreaterEqual,
                    Default::default(),
                ),
                samples: 1,
            });
            Some(PointsPipes { pipeline, bgl })
        } else {
            None
        };
        let decal = if opts.method == Method::Decal {
            let dmod = g.shader("decal.wgsl", DECAL_SHADER)?;
            let (t_on, t_off) = (
                [gpu::target(ID_FORMAT, true)],
                [gpu::target(ID_FORMAT, false)],
            );
            let surface = pipe(
                "decal surface colour",
                &dmod,
                "vs_surface",
                Some(("fs_surface", &t_on)),
                tri,
                depth_state(false, wgpu::CompareFunction::Greater, SURFACE_BIAS),
            );
            // The points write their depth (nudged a hair nearer than their
            // surface), so that a surface drawn later erases a vertex's id
            // only where it is in front of the vertex, not where it merely
            // meets it along an edge.
            let points = pipe(
                "decal points",
                &dmod,
                "vs_point",
                Some(("fs_point", &t_on)),
                pts,
                depth_state(
                    true,
                    wgpu::CompareFunction::GreaterEqual,
                    Default::default(),
                ),
            );
            let depth = pipe(
                "decal surface depth",
                &dmod,
                "vs_surface",
                Some(("fs_surface", &t_off)),
                tri,
                depth_state(true, wgpu::CompareFunction::Greater, SURFACE_BIAS),
            );
            let id_tex = tex(
                "hemicube ids",
                ID_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            );
            let id_view = id_tex.create_view(&Default::default());
            Some(DecalPipes {
                surface,
                points,
                depth,
                id_tex,
                id_view,
            })
        } else {
            None
        };
        g.check()?;
        Ok(Hemicube {
            gpu: Mutex::new(Gpus {
                g,
                vbuf,
                ibuf,
                n_indices,
                surface_ranges,
                shot_buf,
                _face_buf: face_buf,
                bind0,
                bgl1,
                depth_pipeline,
                id_pipeline,
                test_pipeline,
                _surface_ids: surface_ids,
                surface_ids_view,
                normal_buf,
                _depth_tex: depth_tex,
                depth_view,
                points,
                decal,
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

    /// The method in use.
    pub fn method(&self) -> Method {
        self.opts.method
    }

    /// The five faces for a shooter point with normal n.
    fn shot_uniform(&self, from: DVec3, n: DVec3, shooter: SurfaceId, count: usize) -> ShotU {
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
            params: [
                count as f32,
                self.opts.depth_tolerance,
                UNCERTAIN,
                f32::from_bits(shooter.0),
            ],
        }
    }

    /// Records the depth-only pass of all patches into the atlas.
    fn depth_pass(s: &Gpus, enc: &mut wgpu::CommandEncoder, uni: &ShotU) {
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hemicube depth"),
            depth_stencil_attachment: gpu::depth_target(&s.depth_view, Some(0.0)),
            ..Default::default()
        });
        rp.set_pipeline(&s.depth_pipeline);
        rp.set_vertex_buffer(0, s.vbuf.slice(..));
        rp.set_index_buffer(s.ibuf.slice(..), wgpu::IndexFormat::Uint32);
        for (k, f) in uni.faces.iter().enumerate() {
            set_face(&mut rp, f, &s.bind0, k);
            rp.draw_indexed(0..s.n_indices, 0, 0..1);
        }
    }

    /// Records the surface-id pass (depth and ids, no bias) into the atlas.
    fn id_pass(s: &Gpus, enc: &mut wgpu::CommandEncoder, uni: &ShotU) {
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hemicube surface ids"),
            color_attachments: &[gpu::color_target(
                &s.surface_ids_view,
                None,
                Some(wgpu::Color::TRANSPARENT),
            )],
            depth_stencil_attachment: gpu::depth_target(&s.depth_view, Some(0.0)),
            ..Default::default()
        });
        rp.set_pipeline(&s.id_pipeline);
        rp.set_vertex_buffer(0, s.vbuf.slice(..));
        rp.set_index_buffer(s.ibuf.slice(..), wgpu::IndexFormat::Uint32);
        for (k, f) in uni.faces.iter().enumerate() {
            set_face(&mut rp, f, &s.bind0, k);
            rp.draw_indexed(0..s.n_indices, 0, 0..1);
        }
    }

    /// Depth method: per candidate, bit 0 = visible at its pixel, bit 1 = questionable.
    fn depth_flags(&self, s: &Gpus, sh: &Shooter, rel: &[[f32; 4]]) -> Result<Vec<u32>, GpuError> {
        let g = &s.g;
        let mut out = Vec::with_capacity(rel.len());
        // Chunks keep each dispatch within the 65535 × 65535 workgroup grid
        // and the buffers within the device's binding size.
        let chunk = (g.limits.max_storage_buffer_binding_size as usize / 16).clamp(1, 1 << 22);
        let mut first = true;
        for part in rel.chunks(chunk) {
            let uni = self.shot_uniform(sh.from, sh.n, sh.surface, part.len());
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
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::TextureView(&s.surface_ids_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: s.normal_buf.as_entire_binding(),
                    },
                ],
            });
            let mut enc = g.device.create_command_encoder(&Default::default());
            if first {
                Self::id_pass(s, &mut enc, &uni);
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
        Ok(out)
    }

    /// Points method: whether each candidate's point survived the depth test.
    fn points_seen(&self, s: &Gpus, sh: &Shooter, rel: &[[f32; 4]]) -> Result<Vec<bool>, GpuError> {
        let g = &s.g;
        let pp = s
            .points
            .as_ref()
            .ok_or_else(|| GpuError("points pipeline missing".into()))?;
        let uni = self.shot_uniform(sh.from, sh.n, sh.surface, rel.len());
        g.queue
            .write_buffer(&s.shot_buf, 0, bytemuck::bytes_of(&uni));
        let pbuf = g.buffer_init(
            "points",
            bytemuck::cast_slice(rel),
            wgpu::BufferUsages::VERTEX,
        );
        let size = (rel.len() * 4).max(4) as u64;
        let seen = g.buffer_init(
            "seen",
            &vec![0u8; size as usize],
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let bind = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hemicube points"),
            layout: &pp.bgl,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: seen.as_entire_binding(),
            }],
        });
        let mut enc = g.device.create_command_encoder(&Default::default());
        Self::depth_pass(s, &mut enc, &uni);
        {
            let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("hemicube points"),
                depth_stencil_attachment: gpu::depth_target(&s.depth_view, None),
                ..Default::default()
            });
            rp.set_pipeline(&pp.pipeline);
            rp.set_bind_group(1, &bind, &[]);
            rp.set_vertex_buffer(0, pbuf.slice(..));
            for (k, f) in uni.faces.iter().enumerate() {
                set_face(&mut rp, f, &s.bind0, k);
                rp.draw(0..rel.len() as u32, 0..1);
            }
        }
        g.queue.submit([enc.finish()]);
        let bytes = g.read_buffer(&seen, size)?;
        Ok(bytes
            .chunks_exact(4)
            .take(rel.len())
            .map(|b| b[0] != 0)
            .collect())
    }

    /// Decal method: ids left in the id image, redrawn with the vertices not
    /// yet seen until a pass finds no new one (at most 32 passes).
    fn decal_seen(
        &self,
        s: &Gpus,
        mesh: &Mesh,
        sh: &Shooter,
        candidates: &[VertId],
        rel: &[[f32; 4]],
    ) -> Result<Vec<bool>, GpuError> {
        let g = &s.g;
        let dp = s
            .decal
            .as_ref()
            .ok_or_else(|| GpuError("decal pipelines missing".into()))?;
        let uni = self.shot_uniform(sh.from, sh.n, sh.surface, rel.len());
        g.queue
            .write_buffer(&s.shot_buf, 0, bytemuck::bytes_of(&uni));
        let mut seen = vec![false; rel.len()];
        let mut remaining: Vec<usize> = (0..rel.len()).collect();
        for _pass in 0..32 {
            if remaining.is_empty() {
                break;
            }
            // The remaining candidates grouped by surface (surface ids are
            // dense and the ranges are in surface order).
            remaining.sort_by_key(|&i| (mesh.vertex_surface(candidates[i]).0, i));
            let pts: Vec<[f32; 4]> = remaining.iter().map(|&i| rel[i]).collect();
            let mut prange = vec![(0u32, 0u32); s.surface_ranges.len()];
            for (k, &i) in remaining.iter().enumerate() {
                let sid = mesh.vertex_surface(candidates[i]).0 as usize;
                if sid < prange.len() {
                    if prange[sid].1 == 0 {
                        prange[sid].0 = k as u32;
                    }
                    prange[sid].1 += 1;
                }
            }
            let pbuf = g.buffer_init(
                "decal points",
                bytemuck::cast_slice(&pts),
                wgpu::BufferUsages::VERTEX,
            );
            let mut enc = g.device.create_command_encoder(&Default::default());
            {
                let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("hemicube decal"),
                    color_attachments: &[gpu::color_target(
                        &dp.id_view,
                        None,
                        Some(wgpu::Color::TRANSPARENT),
                    )],
                    depth_stencil_attachment: gpu::depth_target(&s.depth_view, Some(0.0)),
                    ..Default::default()
                });
                rp.set_index_buffer(s.ibuf.slice(..), wgpu::IndexFormat::Uint32);
                for (k, f) in uni.faces.iter().enumerate() {
                    set_face(&mut rp, f, &s.bind0, k);
                    for (sid, &(start, count)) in s.surface_ranges.iter().enumerate() {
                        let (pstart, pcount) = prange[sid];
                        if count > 0 {
                            rp.set_vertex_buffer(0, s.vbuf.slice(..));
                            rp.set_pipeline(&dp.surface);
                            rp.draw_indexed(start..start + count, 0, 0..1);
                        }
                        if pcount > 0 {
                            rp.set_vertex_buffer(0, pbuf.slice(..));
                            rp.set_pipeline(&dp.points);
                            rp.draw(pstart..pstart + pcount, 0..1);
                        }
                        if count > 0 {
                            rp.set_vertex_buffer(0, s.vbuf.slice(..));
                            rp.set_pipeline(&dp.depth);
                            rp.draw_indexed(start..start + count, 0, 0..1);
                        }
                    }
                }
            }
            g.queue.submit([enc.finish()]);
            let ids = g.read_texture(&dp.id_tex, 4)?;
            let mut new = 0;
            for b in ids.chunks_exact(4) {
                let id = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                if id > 0 {
                    let i = (id - 1) as usize;
                    if i < seen.len() && !seen[i] {
                        seen[i] = true;
                        new += 1;
                    }
                }
            }
            remaining.retain(|&i| !seen[i]);
            if new == 0 {
                break;
            }
        }
        Ok(seen)
    }

    /// The hemi-cube's answer for each candidate and which of them are
    /// questionable, before any ray casting.
    pub fn classify(
        &self,
        mesh: &Mesh,
        from: DVec3,
        shooter: SurfaceId,
        candidates: &[VertId],
    ) -> Result<Classified, GpuError> {
        if candidates.is_empty() {
            return Ok(Classified::default());
        }
        let n = mesh.surface_normal(shooter).normalize();
        let sh = Shooter {
            from,
            n,
            surface: shooter,
        };
        // Relative positions, and each candidate's index in w (as bits).
        let rel: Vec<[f32; 4]> = candidates
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let d = (mesh.receiver_pos(v) - from).as_vec3();
                [d.x, d.y, d.z, f32::from_bits(i as u32)]
            })
            .collect();
        // For the depth test: w = the vertex's surface id.
        let rel_s: Vec<[f32; 4]> = candidates
            .iter()
            .zip(&rel)
            .map(|(&v, r)| [r[0], r[1], r[2], f32::from_bits(mesh.vertex_surface(v).0)])
            .collect();
        let s = self
            .gpu
            .lock()
            .map_err(|_| GpuError("hemi-cube state poisoned".into()))?;
        // A vertex on its surface's boundary receives a hair inside its
        // surface (`Mesh::receiver_pos`), within a pixel of the border of a
        // face standing there: questionable by construction.
        let mut out = match self.opts.method {
            Method::Depth => {
                let f = self.depth_flags(&s, &sh, &rel_s)?;
                Classified {
                    raw: f.iter().map(|x| x & 1 != 0).collect(),
                    questionable: f.iter().map(|x| x & 2 != 0).collect(),
                }
            }
            Method::Points | Method::Decal => {
                let raw = if self.opts.method == Method::Points {
                    self.points_seen(&s, &sh, &rel)?
                } else {
                    self.decal_seen(&s, mesh, &sh, candidates, &rel)?
                };
                // Questionable: the depth test's neighbourhood disagrees (a
                // shadow edge, a face border or the horizon within a pixel),
                // or a mixed element spans less than a few pixels.
                let f = self.depth_flags(&s, &sh, &rel_s)?;
                drop(s);
                let mut questionable =
                    self.questionable_by_elements(mesh, from, n, candidates, &raw);
                for (q, x) in questionable.iter_mut().zip(&f) {
                    *q |= x & 2 != 0;
                }
                Classified { raw, questionable }
            }
        };
        for (q, &v) in out.questionable.iter_mut().zip(candidates) {
            *q |= mesh.receiver_stepped(v);
        }
        Ok(out)
    }

    /// §4.5: the vertices of every element that has visible and hidden
    /// vertices and spans less than a few hemi-cube pixels, and vertices
    /// within a pixel and a half of the horizon, are questionable.
    fn questionable_by_elements(
        &self,
        mesh: &Mesh,
        from: DVec3,
        n: DVec3,
        candidates: &[VertId],
        raw: &[bool],
    ) -> Vec<bool> {
        let pixel = 2.0 / f64::from(self.opts.res);
        let mut q: Vec<bool> = candidates
            .iter()
            .map(|&v| {
                let d = mesh.receiver_pos(v) - from;
                d.dot(n) < 1.5 * pixel * d.length()
            })
            .collect();
        let mut index = vec![u32::MAX; mesh.num_vertices()];
        for (i, &v) in candidates.iter().enumerate() {
            index[v.idx()] = i as u32;
        }
        for e in mesh.leaves() {
            let c = mesh.elem_corners(e);
            let mut vis = 0;
            let mut hid = 0;
            for &v in c {
                match index[v.idx()] {
                    u32::MAX => {}
                    i if raw[i as usize] => vis += 1,
                    _ => hid += 1,
                }
            }
            if vis > 0 && hid > 0 {
                let dist = (mesh.elem_centroid(e) - from).length().max(1e-300);
                if mesh.elem_longest_edge(e) / dist < 3.0 * pixel {
                    for &v in c {
                        if index[v.idx()] != u32::MAX {
                            q[index[v.idx()] as usize] = true;
                        }
                    }
                }
            }
        }
        q
    }
}

/// A shooter point, its surface's normal and the surface.
struct Shooter {
    from: DVec3,
    n: DVec3,
    surface: SurfaceId,
}

/// Sets the viewport, scissor and face uniform for face k.
fn set_face(rp: &mut wgpu::RenderPass<'_>, f: &FaceU, bind0: &wgpu::BindGroup, k: usize) {
    let [x, y, w, h] = f.viewport;
    rp.set_viewport(x, y, w, h, 0.0, 1.0);
    rp.set_scissor_rect(x as u32, y as u32, w as u32, h as u32);
    rp.set_bind_group(0, bind0, &[(k as u64 * FACE_STRIDE) as u32]);
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
        let c = match self.classify(mesh, from, shooter, candidates) {
            Ok(c) => c,
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
            .zip(&c.questionable)
            .filter(|(_, q)| **q)
            .map(|(v, _)| *v)
            .collect();
        self.questionable
            .fetch_add(q.len() as u64, Ordering::Relaxed);
        let mut rq = self.ray.visible(mesh, from, shooter, &q).into_iter();
        c.raw
            .iter()
            .zip(&c.questionable)
            .map(|(&r, &q)| if q { rq.next().unwrap_or(r) } else { r })
            .collect()
    }

    fn visible_few(
        &self,
        mesh: &Mesh,
        from: DVec3,
        shooter: SurfaceId,
        candidates: &[VertId],
    ) -> Vec<bool> {
        self.ray.visible(mesh, from, shooter, candidates)
    }

    fn visible_pairs(
        &self,
        mesh: &Mesh,
        shooter: SurfaceId,
        piece: &[DVec3],
        pairs: &[(DVec3, VertId)],
        cache: &mut radiosity::PairCache,
    ) -> Vec<bool> {
        self.ray.visible_pairs(mesh, shooter, piece, pairs, cache)
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
