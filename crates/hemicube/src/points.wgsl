// Hemi-cube visibility, method "points": after the depth-only pass of the
// patches (hemicube.wgsl), every candidate vertex is drawn as a one-pixel
// point into each face with the depth test on; a fragment that survives
// the test marks its vertex visible in a storage buffer. Needs
// @early_depth_test(force): otherwise the fragment shader runs (and writes)
// before the depth test rejects occluded points.

@group(1) @binding(0) var<storage, read_write> seen: array<u32>;

struct PointOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
};

// xyz: the vertex relative to the shooter point; w: its index (as bits).
@vertex
fn vs_point(@location(0) rel: vec4<f32>) -> PointOut {
    var o: PointOut;
    // Depth near/z, nudged nearer by the relative tolerance.
    o.clip = clip_of(shot.faces[face_index.index], rel.xyz, shot.origin.w * (1.0 + shot.params.y));
    o.id = bitcast<u32>(rel.w);
    return o;
}

@fragment
@early_depth_test(force)
fn fs_point(in: PointOut) {
    seen[in.id] = 1u;
}
