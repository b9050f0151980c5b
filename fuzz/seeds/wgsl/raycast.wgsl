struct Params { scene: vec2<u32>, count: u32, width: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rays: array<f32>;
@group(0) @binding(2) var<storage, read_write> hits: array<u32>;

const MISS_T: u32 = 0x7f800000u;      // +inf
const NO_PRIMITIVE: u32 = 0xFFFFFFFFu;

fn raygen__cast() {
    let id = rt_launch_index();
    let i = id.y * params.width + id.x;
    if i >= params.count { return; }
    let b = i * 8u;
    let origin = vec3<f32>(rays[b], rays[b + 1u], rays[b + 2u]);
    let direction = vec3<f32>(rays[b + 4u], rays[b + 5u], rays[b + 6u]);
    // Invalid rays run no program (DESIGN.md §4): the payload keeps these miss values.
    var p: RtPayload;
    p[0] = MISS_T;
    p[1] = NO_PRIMITIVE;
    p[2] = NO_PRIMITIVE;
    p[3] = 0u;
    p[4] = 0u;
    rt_trace(params.scene, origin, direction, rays[b + 3u], rays[b + 7u], 0.0,
             0xFFu, RT_RAY_FLAG_DISABLE_ANYHIT, 0u, 1u, 0u, &p);
    let o = i * 5u;
    hits[o] = p[0];
    hits[o + 1u] = p[1];
    hits[o + 2u] = p[2];
    hits[o + 3u] = p[3];
    hits[o + 4u] = p[4];
}

fn closesthit__record() {
    let bary = rt_triangle_barycentrics();
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(1u, rt_primitive_index());
    rt_set_payload(2u, rt_instance_id());
    rt_set_payload(3u, bitcast<u32>(bary.x));
    rt_set_payload(4u, bitcast<u32>(bary.y));
}

fn miss__none() {
}
