// Mitsuba's `mask` as an any-hit program (on PRIM hits, compiled only when a masked material
// exists): the surface is there with probability `opacity` (a texture's luminance, as
// Mitsuba's eval_1) and is passed through otherwise, for radiance and shadow rays alike. The
// decision hashes the ray and the hit, so repeated any-hit calls for one hit agree.

fn anyhit__maskSUFFIX() {
    let h = PRIM_hit();
    var m: MatParams;
    for (var i = 0u; i < 13u; i++) {
        m[i] = rt_sbt_data_f32(SBT_OPACITY + i);
    }
    let opacity = luminance(tex_rgb(m, 0u, h.uv));
    let o = bitcast<vec3<u32>>(rt_world_ray_origin());
    let d = bitcast<vec3<u32>>(rt_world_ray_direction());
    var state = pcg_hash(o.x ^ pcg_hash(o.y ^ pcg_hash(o.z ^ pcg_hash(d.x ^ pcg_hash(d.y
        ^ pcg_hash(d.z ^ pcg_hash(bitcast<u32>(h.t) ^ pcg_hash(rt_primitive_index()
        ^ pcg_hash(rt_instance_index() ^ params.seed)))))))));
    if rng_next(&state) >= opacity {
        rt_ignore_intersection();
    }
}
