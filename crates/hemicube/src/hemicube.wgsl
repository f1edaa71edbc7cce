// Hemi-cube visibility, method "depth": every patch is drawn into five
// hemi-cube faces (an atlas: the full top face, then four half side faces)
// with reversed, infinite-far depth (depth = near / distance along the
// face's axis; larger is nearer), writing its surface's id; then a compute
// pass tests every candidate vertex against its pixel and the 3 × 3 pixels
// around it. A pixel says "visible" when it shows the vertex's own surface or
// something no nearer than the vertex, "hidden" when it shows another
// surface clearly nearer, "uncertain" when another surface is nearer by less
// than a relative margin (a lamp 0.1 mm under its ceiling). Flags: bit 0 =
// the centre pixel's answer (visible), bit 1 = questionable (the
// neighbourhood disagrees or is uncertain, or the vertex is at a face's edge
// or the horizon); the CPU ray casts questionable ones.
//
// (vs_depth with no fragment stage, and a slope-scaled bias, is also the
// depth-only pass the points method draws its vertices against.)

struct IdOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
};

// pos.w holds the patch's surface id (as bits).
@vertex
fn vs_depth(@location(0) pos: vec4<f32>) -> IdOut {
    let face = shot.faces[face_index.index];
    var o: IdOut;
    o.clip = clip_of(face, pos.xyz - shot.origin.xyz, shot.origin.w);
    o.id = bitcast<u32>(pos.w);
    // The shooter's own surface cannot hide anything from a point on it
    // (the ray caster ignores it too); drawn, its edge-on sliver at the
    // horizon would. Such triangles are moved outside the clip volume.
    if o.id == bitcast<u32>(shot.params.w) {
        o.clip = vec4<f32>(2.0, 2.0, 0.5, 1.0);
    }
    return o;
}

@fragment
fn fs_id(in: IdOut) -> @location(0) u32 {
    return in.id + 1u;
}

@group(1) @binding(0) var depth: texture_depth_2d;
@group(1) @binding(1) var<storage, read> candidates: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read_write> flags: array<u32>;
@group(1) @binding(3) var ids: texture_2d<u32>;
// Unit normal of each surface (xyz).
@group(1) @binding(4) var<storage, read> normals: array<vec4<f32>>;

// 1 visible, 0 hidden, 2 uncertain.
fn test_at(texel: vec2<i32>, d: f32, own: u32) -> u32 {
    let id = textureLoad(ids, texel, 0).x;
    if id == 0u || id == own + 1u {
        return 1u;
    }
    let stored = textureLoad(depth, texel, 0);
    if stored <= d * (1.0 + shot.params.y) {
        return 1u;
    }
    if stored > d * (1.0 + shot.params.z) {
        return 0u;
    }
    // Another surface nearer by less than the margin: where it meets the
    // vertex's surface at an angle (a wall on a floor) it passes through the
    // vertex, which the ray caster counts as visible; a layer parallel to it
    // (a lamp under its ceiling, a paper on a desk) is for the rays to decide.
    let other = normals[id - 1u].xyz;
    let mine = normals[own].xyz;
    if abs(dot(other, mine)) < 0.5 {
        return 1u;
    }
    return 2u;
}

@compute @workgroup_size(64)
fn cs_test(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * 65535u * 64u;
    if i >= u32(shot.params.x) {
        return;
    }
    // Candidate position relative to the shooter point; w: its surface id.
    let p = candidates[i].xyz;
    let own = bitcast<u32>(candidates[i].w);
    var result = 2u;
    for (var k = 0u; k < 5u; k = k + 1u) {
        let face = shot.faces[k];
        let z = dot(p, face.fwd.xyz);
        if z <= 0.0 {
            continue;
        }
        let tx = dot(p, face.right.xyz) / z;
        let ty = dot(p, face.up.xyz) / z;
        let w = face.window;
        if tx < w.x || tx > w.y || ty < w.z || ty > w.w {
            continue;
        }
        let vp = face.viewport;
        let fx = (tx - w.x) / (w.y - w.x) * vp.z;
        let fy = (w.w - ty) / (w.w - w.z) * vp.w;
        let px = i32(floor(fx));
        let py = i32(floor(fy));
        let lo = vec2<i32>(vp.xy);
        let hi = lo + vec2<i32>(vp.zw) - vec2<i32>(1, 1);
        let d = shot.origin.w / z;
        let c = test_at(clamp(lo + vec2<i32>(px, py), lo, hi), d, own);
        let centre = c != 0u;
        // At a face's border or the horizon the neighbourhood is cut off.
        if px < 1 || py < 1 || f32(px) > vp.z - 2.0 || f32(py) > vp.w - 2.0 {
            result = 2u | select(0u, 1u, centre);
            break;
        }
        var agree = c != 2u;
        for (var dy = -1; dy <= 1; dy = dy + 1) {
            for (var dx = -1; dx <= 1; dx = dx + 1) {
                let t = clamp(lo + vec2<i32>(px + dx, py + dy), lo, hi);
                if test_at(t, d, own) != c {
                    agree = false;
                }
            }
        }
        result = select(2u, 0u, agree) | select(0u, 1u, centre);
        break;
    }
    flags[i] = result;
}
