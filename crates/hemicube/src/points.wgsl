// Hemi-cube visibility, method "points": after the depth-only pass of the
// patches (hemicube.wgsl), every candidate vertex is drawn as a one-pixel
// point into each face with the depth test on; a fragment that survives
// the test marks its vertex visible in a storage buffer. Needs
// @early_depth_test(force): otherwise the fragment shader runs (and writes)
// before the depth test rejects occluded points.

struct Face {
    right: vec4<f32>,
    up: vec4<f32>,
    fwd: vec4<f32>,
    window: vec4<f32>,
    viewport: vec4<f32>,
};

struct Shot {
    faces: array<Face, 5>,
    origin: vec4<f32>,
    params: vec4<f32>,
};

struct FaceIndex {
    index: u32,
};

@group(0) @binding(0) var<uniform> shot: Shot;
@group(0) @binding(1) var<uniform> face_index: FaceIndex;
@group(1) @binding(0) var<storage, read_write> seen: array<u32>;

struct PointOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
};

// xyz: the vertex relative to the shooter point; w: its index (as bits).
@vertex
fn vs_point(@location(0) rel: vec4<f32>) -> PointOut {
    let face = shot.faces[face_index.index];
    let p = rel.xyz;
    let x = dot(p, face.right.xyz);
    let y = dot(p, face.up.xyz);
    let z = dot(p, face.fwd.xyz);
    let w = face.window;
    var o: PointOut;
    // Depth near/z, nudged nearer by the relative tolerance.
    o.clip = vec4<f32>(
        (2.0 * x - (w.x + w.y) * z) / (w.y - w.x),
        (2.0 * y - (w.z + w.w) * z) / (w.w - w.z),
        shot.origin.w * (1.0 + shot.params.y),
        z
    );
    o.id = bitcast<u32>(rel.w);
    return o;
}

@fragment
@early_depth_test(force)
fn fs_point(in: PointOut) {
    seen[in.id] = 1u;
}
