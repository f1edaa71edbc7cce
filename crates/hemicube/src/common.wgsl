// Shared by the hemi-cube shaders (prepended to each): the five faces of a
// shot, the uniforms, and the projection onto a face.

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
    // x: number of candidates; y: relative depth tolerance; z: uncertain
    // margin; w: the shooter's surface id (bits).
    params: vec4<f32>,
};

struct FaceIndex {
    index: u32,
};

@group(0) @binding(0) var<uniform> shot: Shot;
@group(0) @binding(1) var<uniform> face_index: FaceIndex;

// Clip position of p (relative to the shooter point) on a face, with depth
// `depth` / (distance along the face's axis): reversed, infinite far.
fn clip_of(face: Face, p: vec3<f32>, depth: f32) -> vec4<f32> {
    let x = dot(p, face.right.xyz);
    let y = dot(p, face.up.xyz);
    let z = dot(p, face.fwd.xyz);
    let w = face.window;
    return vec4<f32>(
        (2.0 * x - (w.x + w.y) * z) / (w.y - w.x),
        (2.0 * y - (w.z + w.w) * z) / (w.w - w.z),
        depth,
        z
    );
}
