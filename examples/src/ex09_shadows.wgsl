// ex09: a second ray type. Radiance rays use SBT offset 0 and miss program 0; shadow rays use
// SBT offset 1 and miss program 1, with stride 2 (each mesh has a radiance and a shadow hit
// record). A shadow ray disables closest-hit and any-hit and stops at the first hit, so only
// its miss program can run: it marks the light visible.
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
    light_position: vec4<f32>,
}
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> image: array<vec4<f32>>;

const RADIANCE_RAY: u32 = 0u;
const SHADOW_RAY: u32 = 1u;
const RAY_TYPE_COUNT: u32 = 2u;

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
        RT_RAY_FLAG_DISABLE_ANYHIT, RADIANCE_RAY, RAY_TYPE_COUNT, RADIANCE_RAY, &payload);
    let color = vec3<f32>(bitcast<f32>(payload[0]), bitcast<f32>(payload[1]),
        bitcast<f32>(payload[2]));
    image[px.y * params.width + px.x] = vec4<f32>(color, 1.0);
}

fn closesthit__radiance() {
    let s = hit_surface();
    // The shadow ray: from just above the surface to just short of the light, unnormalised
    // so that t = 1 is the light.
    let to_light = params.light_position.xyz - s.position;
    var shadow: RtPayload;
    shadow[0] = bitcast<u32>(0.0);
    rt_trace(params.scene, s.position + 1e-3 * s.geometric_normal, to_light, 1e-3, 1.0 - 1e-3,
        0.0, 0xFFu,
        RT_RAY_FLAG_DISABLE_ANYHIT | RT_RAY_FLAG_TERMINATE_ON_FIRST_HIT
            | RT_RAY_FLAG_DISABLE_CLOSESTHIT,
        SHADOW_RAY, RAY_TYPE_COUNT, SHADOW_RAY, &shadow);
    let visibility = bitcast<f32>(shadow[0]);
    let cos_dn = 0.1 + 0.8 * abs(dot(rt_world_ray_direction(), s.shading_normal));
    set_color((0.1 + (0.2 + 0.8 * visibility) * cos_dn) * s.diffuse);
}

fn miss__radiance() {
    set_color(vec3<f32>(1.0));
}

// Never runs (shadow rays disable closest-hit); the SBT's shadow records still name a group.
fn closesthit__shadow() {}

fn miss__shadow() {
    rt_set_payload(0u, bitcast<u32>(1.0));
}
