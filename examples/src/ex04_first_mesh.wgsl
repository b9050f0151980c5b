// ex04: the first triangle mesh. The raygen program shoots one ray per pixel through the
// course's pinhole camera; the closest-hit program colours each triangle by its index, the miss
// program writes white. The payload carries the colour back in three registers (the course
// passes a pointer to a per-ray struct instead; optik's payload registers are copied in and
// out, as values).
struct Camera {
    position: vec4<f32>,
    direction: vec4<f32>,
    horizontal: vec4<f32>,
    vertical: vec4<f32>,
}
struct Params {
    scene: vec2<u32>,
    width: u32,
    height: u32,
    camera: Camera,
}
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> image: array<vec4<f32>>;

// The course's randomColor(i).
fn random_color(i: u32) -> vec3<f32> {
    let r = i * (13u * 17u) + 0x234235u;
    let g = i * (7u * 3u * 5u) + 0x773477u;
    let b = i * (11u * 19u) + 0x223766u;
    return vec3<f32>(f32(r & 255u), f32(g & 255u), f32(b & 255u)) / 255.0;
}

fn set_color(c: vec3<f32>) {
    rt_set_payload(0u, bitcast<u32>(c.x));
    rt_set_payload(1u, bitcast<u32>(c.y));
    rt_set_payload(2u, bitcast<u32>(c.z));
}

fn raygen__render_frame() {
    let px = rt_launch_index().xy;
    // Pixel centre in [0, 1]²; row 0 is the top of the image.
    let screen = vec2<f32>(
        (f32(px.x) + 0.5) / f32(params.width),
        1.0 - (f32(px.y) + 0.5) / f32(params.height),
    );
    let c = params.camera;
    let dir = normalize(c.direction.xyz + (screen.x - 0.5) * c.horizontal.xyz
        + (screen.y - 0.5) * c.vertical.xyz);
    var payload: RtPayload;
    rt_trace(params.scene, c.position.xyz, dir, 0.0, 1e20, 0.0, 0xFFu,
        RT_RAY_FLAG_DISABLE_ANYHIT, 0u, 1u, 0u, &payload);
    let color = vec3<f32>(bitcast<f32>(payload[0]), bitcast<f32>(payload[1]),
        bitcast<f32>(payload[2]));
    image[px.y * params.width + px.x] = vec4<f32>(color, 1.0);
}

fn closesthit__radiance() {
    set_color(random_color(rt_primitive_index()));
}

fn miss__radiance() {
    set_color(vec3<f32>(1.0));
}
