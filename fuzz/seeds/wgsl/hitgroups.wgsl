struct Params { scene: vec2<u32>, width: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> image: array<vec4<f32>>;

fn raygen__camera() {
    let id = rt_launch_index();
    let dims = rt_launch_dimensions();
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(dims.xy);
    var p: RtPayload;
    rt_trace(params.scene, vec3<f32>(uv, -1.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0,
             0xFFu, RT_RAY_FLAG_NONE, 0u, 1u, 0u, &p);
    image[id.y * dims.x + id.x] = vec4<f32>(bitcast<f32>(p[0]), bitcast<f32>(p[1]), 0.0, 1.0);
}

fn intersection__sphere() {
    let o = rt_object_ray_origin();
    let d = rt_object_ray_direction();
    let b = dot(o, d);
    let c = dot(o, o) - 1.0;
    let h = b * b - dot(d, d) * c;
    if h >= 0.0 {
        var a: array<u32, 8>;
        a[0] = bitcast<u32>(h);
        _ = rt_report_intersection((-b - sqrt(h)) / dot(d, d), 0u, a);
    }
}

fn anyhit__cutout() {
    let bary = rt_triangle_barycentrics();
    if bary.x > 0.5 {
        rt_ignore_intersection();
    }
    if rt_hit_kind() == RT_HIT_KIND_TRIANGLE_BACK_FACE {
        rt_terminate_ray();
    }
}

fn closesthit__shade() {
    let n = rt_object_to_world();
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(1u, rt_primitive_index() + rt_instance_id() + rt_sbt_data_u32(0u));
    _ = n;
}

fn miss__background() {
    rt_set_payload(0u, bitcast<u32>(-1.0));
}

fn exception__report() {
    rt_set_payload(1u, u32(rt_exception_code()));
}
