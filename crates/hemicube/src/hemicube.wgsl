// Hemi-cube visibility, method "depth": a depth-only pass of every patch
// into five hemi-cube faces (an atlas: the full top face, then four half
// side faces), with reversed, infinite-far depth (depth = near / distance
// along the face's axis; larger is nearer) and a slope-scaled bias; then a
// compute pass tests every candidate vertex against the depth of its pixel
// and the 3 × 3 pixels around it: 1 = visible, 0 = hidden, 2 = questionable
// (the neighbourhood disagrees, or the vertex is at a face's edge or the
// horizon), which the CPU then ray casts.

struct Face {
    // Basis of the face's view: right, up, forward (xyz), and the window in
    // tangent units: x0, x1, y0, y1.
    right: vec4<f32>,
    up: vec4<f32>,
    fwd: vec4<f32>,
    window: vec4<f32>,
    // Viewport in the atlas: x, y, width, height (pixels).
    viewport: vec4<f32>,
};

struct Shot {
    faces: array<Face, 5>,
    // xyz: the shooter point relative to the scene origin; w: near distance.
    origin: vec4<f32>,
    // x: number of candidates; y: relative depth tolerance.
    params: vec4<f32>,
};

struct FaceIndex {
    index: u32,
};

@group(0) @binding(0) var<uniform> shot: Shot;
@group(0) @binding(1) var<uniform> face_index: FaceIndex;

fn clip_of(face: Face, p: vec3<f32>, near: f32) -> vec4<f32> {
    let x = dot(p, face.right.xyz);
    let y = dot(p, face.up.xyz);
    let z = dot(p, face.fwd.xyz);
    let w = face.window;
    return vec4<f32>(
        (2.0 * x - (w.x + w.y) * z) / (w.y - w.x),
        (2.0 * y - (w.z + w.w) * z) / (w.w - w.z),
        near,
        z
    );
}

@vertex
fn vs_depth(@location(0) pos: vec3<f32>) -> @builtin(position) vec4<f32> {
    let face = shot.faces[face_index.index];
    return clip_of(face, pos - shot.origin.xyz, shot.origin.w);
}

@group(1) @binding(0) var depth: texture_depth_2d;
@group(1) @binding(1) var<storage, read> candidates: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read_write> flags: array<u32>;

fn visible_at(texel: vec2<i32>, d: f32) -> bool {
    let stored = textureLoad(depth, texel, 0);
    return d * (1.0 + shot.params.y) >= stored;
}

@compute @workgroup_size(64)
fn cs_test(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * 65535u * 64u;
    if i >= u32(shot.params.x) {
        return;
    }
    // Candidate position relative to the shooter point.
    let p = candidates[i].xyz;
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
        // At a face's border or the horizon the neighbourhood is cut off.
        if px < 1 || py < 1 || f32(px) > vp.z - 2.0 || f32(py) > vp.w - 2.0 {
            result = 2u;
            break;
        }
        let centre = visible_at(lo + vec2<i32>(px, py), d);
        var agree = true;
        for (var dy = -1; dy <= 1; dy = dy + 1) {
            for (var dx = -1; dx <= 1; dx = dx + 1) {
                let t = clamp(lo + vec2<i32>(px + dx, py + dy), lo, hi);
                if visible_at(t, d) != centre {
                    agree = false;
                }
            }
        }
        if agree {
            result = select(0u, 1u, centre);
        } else {
            result = 2u;
        }
        break;
    }
    flags[i] = result;
}
