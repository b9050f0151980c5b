// A camera, a closest-hit that shades by primitive, and a miss: the shape of the OptiX 7 course's
// first triangle-mesh example.
struct Params {
    scene: vec2<u32>,
    width: u32,
    height: u32,
    eye: vec4<f32>,
}
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> image: array<u32>;

fn pack_rgba(c: vec3<f32>) -> u32 {
    let q = vec3<u32>(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)) * 255.0);
    return q.x | (q.y << 8u) | (q.z << 16u) | 0xFF000000u;
}

fn raygen__camera() {
    let px = rt_launch_index().xy;
    let uv = (vec2<f32>(px) + 0.5) / vec2<f32>(f32(params.width), f32(params.height));
    let dir = normalize(vec3<f32>(uv * 2.0 - 1.0, -1.0));
    var payload: RtPayload;
    rt_trace(params.scene, params.eye.xyz, dir, 0.0, 1e30, 0.0,
             0xFFu, RT_RAY_FLAG_NONE, 0u, 1u, 0u, &payload);
    image[px.y * params.width + px.x] = payload[0];
}

fn closesthit__shade() {
    let bary = rt_triangle_barycentrics();
    let shade = vec3<f32>(1.0 - bary.x - bary.y, bary.x, bary.y);
    rt_set_payload(0u, pack_rgba(shade));
}

fn miss__background() {
    rt_set_payload(0u, pack_rgba(vec3<f32>(0.2, 0.2, 0.3)));
}
