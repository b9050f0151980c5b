// The surface at a closest hit, shared by ex08 and later: the meshes' storage buffers, their
// textures, and the hit point's geometric normal, shading normal and diffuse colour.
//
// Hit record data (the course's TriangleMeshSBTData), word by word:
//   0..3 diffuse colour (f32), 3 first vertex, 4 first triangle,
//   5 flags (1: has normals, 2: has texture coordinates), 6 texture slot (0xFFFFFFFF: none).
@group(0) @binding(2) var<storage, read> positions: array<f32>;
@group(0) @binding(3) var<storage, read> indices: array<u32>;
@group(0) @binding(4) var<storage, read> normals: array<f32>;
@group(0) @binding(5) var<storage, read> texcoords: array<f32>;
@group(0) @binding(6) var tex_sampler: sampler;
// optik binds textures by number, so a model's textures take fixed slots (the course keeps a
// CUDA texture object per mesh in its SBT data instead).
@group(0) @binding(7) var texture0: texture_2d<f32>;
@group(0) @binding(8) var texture1: texture_2d<f32>;
@group(0) @binding(9) var texture2: texture_2d<f32>;
@group(0) @binding(10) var texture3: texture_2d<f32>;

const NO_TEXTURE: u32 = 0xFFFFFFFFu;

struct Surface {
    position: vec3<f32>,
    // Both normals face the incoming ray.
    geometric_normal: vec3<f32>,
    shading_normal: vec3<f32>,
    diffuse: vec3<f32>,
}

fn vertex_position(v: u32) -> vec3<f32> {
    return vec3<f32>(positions[3u * v], positions[3u * v + 1u], positions[3u * v + 2u]);
}

fn vertex_normal(v: u32) -> vec3<f32> {
    return vec3<f32>(normals[3u * v], normals[3u * v + 1u], normals[3u * v + 2u]);
}

fn vertex_texcoord(v: u32) -> vec2<f32> {
    return vec2<f32>(texcoords[2u * v], texcoords[2u * v + 1u]);
}

fn sample_texture(slot: u32, uv: vec2<f32>) -> vec4<f32> {
    var texel = vec4<f32>(1.0);
    switch slot {
        case 0u: { texel = textureSampleLevel(texture0, tex_sampler, uv, 0.0); }
        case 1u: { texel = textureSampleLevel(texture1, tex_sampler, uv, 0.0); }
        case 2u: { texel = textureSampleLevel(texture2, tex_sampler, uv, 0.0); }
        case 3u: { texel = textureSampleLevel(texture3, tex_sampler, uv, 0.0); }
        default: {}
    }
    return texel;
}

// The surface hit by the current ray (call from a closest-hit program).
fn hit_surface() -> Surface {
    let first_vertex = rt_sbt_data_u32(3u);
    let t = 3u * (rt_sbt_data_u32(4u) + rt_primitive_index());
    let i0 = first_vertex + indices[t];
    let i1 = first_vertex + indices[t + 1u];
    let i2 = first_vertex + indices[t + 2u];
    let a = vertex_position(i0);
    let b = vertex_position(i1);
    let c = vertex_position(i2);
    let bary = rt_triangle_barycentrics();
    let w = vec3<f32>(1.0 - bary.x - bary.y, bary.x, bary.y);
    let ray_dir = rt_world_ray_direction();

    var s: Surface;
    s.position = w.x * a + w.y * b + w.z * c;
    var ng = normalize(cross(b - a, c - a));
    let flags = rt_sbt_data_u32(5u);
    var ns = ng;
    if (flags & 1u) != 0u {
        let n = w.x * vertex_normal(i0) + w.y * vertex_normal(i1) + w.z * vertex_normal(i2);
        if dot(n, n) > 0.0 {
            ns = normalize(n);
        }
    }
    // Face-forward both normals towards the viewer, as the course does from ex09 on.
    if dot(ray_dir, ng) > 0.0 {
        ng = -ng;
    }
    if dot(ng, ns) < 0.0 {
        ns = ns - 2.0 * dot(ng, ns) * ng;
    }
    s.geometric_normal = ng;
    s.shading_normal = ns;

    s.diffuse = vec3<f32>(rt_sbt_data_f32(0u), rt_sbt_data_f32(1u), rt_sbt_data_f32(2u));
    let slot = rt_sbt_data_u32(6u);
    if slot != NO_TEXTURE && (flags & 2u) != 0u {
        let uv = w.x * vertex_texcoord(i0) + w.y * vertex_texcoord(i1)
            + w.z * vertex_texcoord(i2);
        s.diffuse = s.diffuse * sample_texture(slot, uv).rgb;
    }
    return s;
}

// The course's camera ray through pixel `px` at sub-pixel offset `jitter` in [0, 1)²; row 0 is
// the top of the image.
fn camera_ray(px: vec2<u32>, jitter: vec2<f32>) -> vec3<f32> {
    let screen = vec2<f32>(
        (f32(px.x) + jitter.x) / f32(params.width),
        1.0 - (f32(px.y) + jitter.y) / f32(params.height),
    );
    let c = params.camera;
    return normalize(c.direction.xyz + (screen.x - 0.5) * c.horizontal.xyz
        + (screen.y - 0.5) * c.vertical.xyz);
}
