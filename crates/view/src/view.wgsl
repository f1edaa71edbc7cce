// ugview: surfaces (Gouraud-shaded radiance, or flat-shaded material colour)
// and mesh lines. Two targets: 0 = HDR radiance with coverage in alpha,
// 1 = overlay (mesh lines, back-face marking) composited after tone mapping.

struct Uniforms {
    view_proj: mat4x4<f32>,
    // xyz: eye position (perspective) or view direction (orthographic); w: 1 if orthographic.
    eye: vec4<f32>,
    // Cut plane: fragments with dot(xyz, p) > w are discarded; xyz = 0 disables.
    cut: vec4<f32>,
    // x: colour scale; y: 1 lit, 0 unlit (headlight shading); z: 1 marks back faces;
    // w: depth pull of lines toward the eye (clip-space z per w).
    params: vec4<f32>,
    line_colour: vec4<f32>,
};

@group(0) @binding(0) var<uniform> u: Uniforms;

struct VIn {
    @location(0) pos: vec3<f32>,
    @location(1) colour: vec3<f32>,
    @location(2) normal: vec3<f32>,
};

struct VOut {
    @builtin(position) clip: vec4<f32>,
    // Centroid: with multisampling a pixel whose centre lies outside a thin
    // triangle would otherwise extrapolate the colour (to below zero).
    @location(0) @interpolate(perspective, centroid) colour: vec3<f32>,
    @location(1) @interpolate(perspective, centroid) world: vec3<f32>,
    @location(2) @interpolate(flat) normal: vec3<f32>,
};

struct FOut {
    @location(0) hdr: vec4<f32>,
    @location(1) overlay: vec4<f32>,
};

fn cut_away(p: vec3<f32>) -> bool {
    return any(u.cut.xyz != vec3<f32>(0.0)) && dot(u.cut.xyz, p) > u.cut.w;
}

fn transform(v: VIn) -> VOut {
    var o: VOut;
    o.clip = u.view_proj * vec4<f32>(v.pos, 1.0);
    o.colour = v.colour;
    o.world = v.pos;
    o.normal = v.normal;
    return o;
}

@vertex
fn vs_surface(v: VIn) -> VOut {
    return transform(v);
}

@fragment
fn fs_surface(in: VOut, @builtin(front_facing) front: bool) -> FOut {
    if cut_away(in.world) {
        discard;
    }
    var o: FOut;
    o.overlay = vec4<f32>(0.0);
    if !front {
        // Only reached with --backfaces (culling is off then).
        o.hdr = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        o.overlay = vec4<f32>(1.0, 0.0, 1.0, 1.0);
        return o;
    }
    var c = in.colour;
    if u.params.y < 0.5 {
        var d = -u.eye.xyz;
        if u.eye.w < 0.5 {
            d = u.eye.xyz - in.world;
        }
        let k = abs(dot(normalize(in.normal), normalize(d)));
        c = c * (0.3 + 0.7 * k);
    }
    o.hdr = vec4<f32>(max(c, vec3<f32>(0.0)) * u.params.x, 1.0);
    return o;
}

@vertex
fn vs_line(v: VIn) -> VOut {
    var o = transform(v);
    // Pull lines slightly toward the eye so that they win the depth test
    // against their own surface (depth bias does not apply to lines).
    o.clip.z = o.clip.z - u.params.w * o.clip.w;
    return o;
}

@fragment
fn fs_line(in: VOut) -> FOut {
    if cut_away(in.world) {
        discard;
    }
    var o: FOut;
    o.hdr = vec4<f32>(0.0);
    o.overlay = u.line_colour;
    return o;
}
