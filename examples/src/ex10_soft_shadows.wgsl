// ex10 and ex11: soft shadows from a quad light. The per-ray data is now a random number
// generator's state and the pixel colour: four payload registers, which the closest-hit
// program reads and writes (the course passes a pointer to the same struct). Each launch
// traces `pixel_samples` jittered rays per pixel, each taking `light_samples` shadow rays to
// random points on the light; the raygen program folds the launch into a running mean over
// frames (ex11's accumulation).
struct Camera {
    position: vec4<f32>,
    direction: vec4<f32>,
    horizontal: vec4<f32>,
    vertical: vec4<f32>,
}
struct QuadLight {
    origin: vec4<f32>,
    du: vec4<f32>,
    dv: vec4<f32>,
    power: vec4<f32>,
}
struct Params {
    scene: vec2<u32>,
    width: u32,
    height: u32,
    camera: Camera,
    light: QuadLight,
    frame_id: u32,
    pixel_samples: u32,
    light_samples: u32,
    pad: u32,
}
@group(0) @binding(0) var<uniform> params: Params;
// The running mean of every frame so far.
@group(0) @binding(1) var<storage, read_write> image: array<vec4<f32>>;

const RADIANCE_RAY: u32 = 0u;
const SHADOW_RAY: u32 = 1u;
const RAY_TYPE_COUNT: u32 = 2u;

// The course's LCG<16>: a tiny-encryption-algorithm hash seeds a linear congruential
// generator, so neighbouring pixels and frames get unrelated sequences.
fn lcg_init(val0: u32, val1: u32) -> u32 {
    var v0 = val0;
    var v1 = val1;
    var s0 = 0u;
    for (var n = 0u; n < 16u; n++) {
        s0 += 0x9e3779b9u;
        v0 += ((v1 << 4u) + 0xa341316cu) ^ (v1 + s0) ^ ((v1 >> 5u) + 0xc8013ea4u);
        v1 += ((v0 << 4u) + 0xad90777du) ^ (v0 + s0) ^ ((v0 >> 5u) + 0x7e95761eu);
    }
    return v0;
}

// The next number in [0, 1).
fn lcg_next(state: ptr<function, u32>) -> f32 {
    *state = 1664525u * *state + 1013904223u;
    return f32(*state & 0x00FFFFFFu) / f32(0x01000000u);
}

fn raygen__render_frame() {
    let px = rt_launch_index().xy;
    var rng = lcg_init(px.x + params.frame_id * params.width,
        px.y + params.frame_id * params.height);
    var sum = vec3<f32>(0.0);
    for (var s = 0u; s < params.pixel_samples; s++) {
        let jitter = vec2<f32>(lcg_next(&rng), lcg_next(&rng));
        let dir = camera_ray(px, jitter);
        var prd: RtPayload;
        prd[0] = rng;
        rt_trace(params.scene, params.camera.position.xyz, dir, 0.0, 1e20, 0.0, 0xFFu,
            RT_RAY_FLAG_DISABLE_ANYHIT, RADIANCE_RAY, RAY_TYPE_COUNT, RADIANCE_RAY, &prd);
        rng = prd[0];
        sum += vec3<f32>(bitcast<f32>(prd[1]), bitcast<f32>(prd[2]), bitcast<f32>(prd[3]));
    }
    let color = sum / f32(params.pixel_samples);
    let i = px.y * params.width + px.x;
    let f = f32(params.frame_id);
    // ex11: the running mean (c + frame · old) / (frame + 1); frame 0 overwrites.
    image[i] = vec4<f32>((color + f * image[i].xyz) / (f + 1.0), 1.0);
}

fn closesthit__radiance() {
    let s = hit_surface();
    let ray_dir = rt_world_ray_direction();
    var rng = rt_get_payload(0u);
    // The course's ambient term, then the light's direct contribution.
    var color = (0.1 + 0.2 * abs(dot(s.shading_normal, ray_dir))) * s.diffuse;
    let light = params.light;
    for (var k = 0u; k < params.light_samples; k++) {
        let light_pos = light.origin.xyz + lcg_next(&rng) * light.du.xyz
            + lcg_next(&rng) * light.dv.xyz;
        var light_dir = light_pos - s.position;
        let light_dist = length(light_dir);
        light_dir = light_dir / light_dist;
        let n_dot_l = dot(light_dir, s.shading_normal);
        // The light emits downwards only: the course omits this cosine, which lets the quad
        // light points above it (the ceiling) with an unbounded 1/distance² glare.
        let light_normal = normalize(cross(light.du.xyz, light.dv.xyz));
        let emit_cos = max(0.0, dot(-light_dir, light_normal));
        if n_dot_l >= 0.0 && emit_cos > 0.0 {
            var shadow: RtPayload;
            shadow[0] = bitcast<u32>(0.0);
            rt_trace(params.scene, s.position + 1e-3 * s.geometric_normal, light_dir, 1e-3,
                light_dist * (1.0 - 1e-3), 0.0, 0xFFu,
                RT_RAY_FLAG_DISABLE_ANYHIT | RT_RAY_FLAG_TERMINATE_ON_FIRST_HIT
                    | RT_RAY_FLAG_DISABLE_CLOSESTHIT,
                SHADOW_RAY, RAY_TYPE_COUNT, SHADOW_RAY, &shadow);
            let visibility = bitcast<f32>(shadow[0]);
            color += visibility * light.power.xyz * s.diffuse
                * (n_dot_l * emit_cos / (light_dist * light_dist * f32(params.light_samples)));
        }
    }
    rt_set_payload(0u, rng);
    rt_set_payload(1u, bitcast<u32>(color.x));
    rt_set_payload(2u, bitcast<u32>(color.y));
    rt_set_payload(3u, bitcast<u32>(color.z));
}

fn miss__radiance() {
    rt_set_payload(1u, bitcast<u32>(1.0));
    rt_set_payload(2u, bitcast<u32>(1.0));
    rt_set_payload(3u, bitcast<u32>(1.0));
}

fn closesthit__shadow() {}

fn miss__shadow() {
    rt_set_payload(0u, bitcast<u32>(1.0));
}
