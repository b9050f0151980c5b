// The BSDF probe: ray generation programs that call one BSDF kind's functions directly, so
// tests compare the renderer's own BSDF code with Mitsuba's.

@group(0) @binding(1) var<storage, read_write> probe_out: array<f32>;
@group(0) @binding(2) var<storage, read> probe_in: array<f32>;
@group(0) @binding(3) var<storage, read> probe_mat: array<f32>;

fn probe_material() -> MatParams {
    var m: MatParams;
    for (var i = 0u; i < MAT_PARAMS_LEN; i++) {
        m[i] = probe_mat[i];
    }
    return m;
}

// Word `i` of the probed material: its precomputed table follows its parameters.
fn mat_extra(i: u32) -> f32 {
    return probe_mat[i];
}

// A twosided pair's back side: parameters and table after the front's
// (material::Encoded::words).
fn back_material() -> MatParams {
    var m: MatParams;
    for (var i = 0u; i < MAT_PARAMS_LEN; i++) {
        m[i] = probe_mat[MATERIAL_WORDS + i];
    }
    return m;
}

fn probe_v3(b: u32) -> vec3<f32> {
    return vec3<f32>(probe_in[b], probe_in[b + 1u], probe_in[b + 2u]);
}

// In: wi, wo, uv (8 floats). Out: value (f · |cos θo|) rgb, pdf.
fn raygen__probe_eval() {
    let i = rt_launch_index().x;
    if i >= params.probe_count {
        return;
    }
    let b = i * 8u;
    let ev = bsdf_KIND_eval_sided(probe_material(), probe_v3(b), probe_v3(b + 3u),
                            vec2<f32>(probe_in[b + 6u], probe_in[b + 7u]));
    probe_out[i * 4u] = ev.x;
    probe_out[i * 4u + 1u] = ev.y;
    probe_out[i * 4u + 2u] = ev.z;
    probe_out[i * 4u + 3u] = ev.w;
}

// In: wi, u1, u2.xy, uv (8 floats). Out: wo, weight rgb, pdf, eta, lobe (0 smooth, 1 delta,
// 2 null): 9 of 12 floats.
fn raygen__probe_sample() {
    let i = rt_launch_index().x;
    if i >= params.probe_count {
        return;
    }
    let b = i * 8u;
    let s = bsdf_KIND_sample_sided(probe_material(), probe_v3(b),
                             vec2<f32>(probe_in[b + 6u], probe_in[b + 7u]), probe_in[b + 3u],
                             vec2<f32>(probe_in[b + 4u], probe_in[b + 5u]));
    let o = i * 12u;
    probe_out[o] = s.wo.x;
    probe_out[o + 1u] = s.wo.y;
    probe_out[o + 2u] = s.wo.z;
    probe_out[o + 3u] = s.weight.x;
    probe_out[o + 4u] = s.weight.y;
    probe_out[o + 5u] = s.weight.z;
    probe_out[o + 6u] = s.pdf;
    probe_out[o + 7u] = s.eta;
    probe_out[o + 8u] = f32(s.delta);
}
