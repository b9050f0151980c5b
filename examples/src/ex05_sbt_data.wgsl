// ex05: per-geometry data in the shader binding table. The hit record now carries the mesh's
// colour and where its vertices and triangles start in the storage buffers; the closest-hit
// program reads them with rt_sbt_data_f32/u32, fetches the triangle's corners itself and
// shades by the angle between the ray and the geometric normal.
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
// Every mesh's vertex positions (x, y, z, x, y, z, ...) and triangles (i0, i1, i2, ...).
@group(0) @binding(2) var<storage, read> positions: array<f32>;
@group(0) @binding(3) var<storage, read> indices: array<u32>;

// The hit record's data (the course's TriangleMeshSBTData), word by word.
const SBT_COLOR: u32 = 0u;          // 3 × f32
const SBT_FIRST_VERTEX: u32 = 3u;   // u32
const SBT_FIRST_TRIANGLE: u32 = 4u; // u32

fn set_color(c: vec3<f32>) {
    rt_set_payload(0u, bitcast<u32>(c.x));
    rt_set_payload(1u, bitcast<u32>(c.y));
    rt_set_payload(2u, bitcast<u32>(c.z));
}

fn vertex(i: u32) -> vec3<f32> {
    let v = rt_sbt_data_u32(SBT_FIRST_VERTEX) + i;
    return vec3<f32>(positions[3u * v], positions[3u * v + 1u], positions[3u * v + 2u]);
}

fn raygen__render_frame() {
    let px = rt_launch_index().xy;
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
    let t = 3u * (rt_sbt_data_u32(SBT_FIRST_TRIANGLE) + rt_primitive_index());
    let a = vertex(indices[t]);
    let b = vertex(indices[t + 1u]);
    let c = vertex(indices[t + 2u]);
    let ng = normalize(cross(b - a, c - a));
    let ray_dir = rt_world_ray_direction();
    let cos_dn = 0.2 + 0.8 * abs(dot(ray_dir, ng));
    let color = vec3<f32>(rt_sbt_data_f32(SBT_COLOR), rt_sbt_data_f32(SBT_COLOR + 1u),
        rt_sbt_data_f32(SBT_COLOR + 2u));
    set_color(cos_dn * color);
}

fn miss__radiance() {
    set_color(vec3<f32>(1.0));
}
