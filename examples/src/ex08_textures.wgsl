// ex08: textures. The closest-hit program interpolates the shading normal and texture
// coordinates with the barycentrics and multiplies the MTL colour by the texture (the surface
// code is in surface.wgsl).
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

fn set_color(c: vec3<f32>) {
    rt_set_payload(0u, bitcast<u32>(c.x));
    rt_set_payload(1u, bitcast<u32>(c.y));
    rt_set_payload(2u, bitcast<u32>(c.z));
}

fn raygen__render_frame() {
    let px = rt_launch_index().xy;
    let dir = camera_ray(px, vec2<f32>(0.5));
    var payload: RtPayload;
    rt_trace(params.scene, params.camera.position.xyz, dir, 0.0, 1e20, 0.0, 0xFFu,
        RT_RAY_FLAG_DISABLE_ANYHIT, 0u, 1u, 0u, &payload);
    let color = vec3<f32>(bitcast<f32>(payload[0]), bitcast<f32>(payload[1]),
        bitcast<f32>(payload[2]));
    image[px.y * params.width + px.x] = vec4<f32>(color, 1.0);
}

fn closesthit__radiance() {
    let s = hit_surface();
    let cos_dn = 0.2 + 0.8 * abs(dot(rt_world_ray_direction(), s.shading_normal));
    set_color(cos_dn * s.diffuse);
}

fn miss__radiance() {
    set_color(vec3<f32>(1.0));
}
