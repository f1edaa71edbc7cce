// Hemi-cube visibility, method "decal" (report §4.3): per surface, its
// polygons in colour only (id 0, depth-tested, no depth write, erasing the
// ids of vertices they hide), then its vertices as one-pixel points writing
// their ids (depth-tested against the surfaces drawn before, so a vertex is
// not hidden by its own surface), then its polygons depth-only. The id image
// is read back; vertices that shared a pixel with another are found by
// drawing again with only the vertices not yet seen (§4.4).

// pos.w: the patch's surface id (bits); the shooter's own surface is not drawn.
@vertex
fn vs_surface(@location(0) pos: vec4<f32>) -> @builtin(position) vec4<f32> {
    if bitcast<u32>(pos.w) == bitcast<u32>(shot.params.w) {
        return vec4<f32>(2.0, 2.0, 0.5, 1.0);
    }
    return clip_of(shot.faces[face_index.index], pos.xyz - shot.origin.xyz, shot.origin.w);
}

@fragment
fn fs_surface() -> @location(0) u32 {
    return 0u;
}

struct PointOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
};

// xyz: the vertex relative to the shooter point; w: its index (as bits).
@vertex
fn vs_point(@location(0) rel: vec4<f32>) -> PointOut {
    var o: PointOut;
    o.clip = clip_of(shot.faces[face_index.index], rel.xyz, shot.origin.w * (1.0 + shot.params.y));
    o.id = bitcast<u32>(rel.w);
    return o;
}

@fragment
fn fs_point(in: PointOut) -> @location(0) u32 {
    return in.id + 1u;
}
