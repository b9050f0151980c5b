// The closest-hit program of one BSDF kind (KIND) on one primitive type (PRIM: mesh or
// sphere), instantiated once per pair present. SMOOTH says whether the BSDF has a non-delta
// lobe, i.e. whether next-event estimation applies.

fn closesthit__KINDSUFFIX() {
    let h = PRIM_hit();
    let d = rt_world_ray_direction();
    PRIM_emission(h, d);
    var rng = rt_get_payload(P_RNG);
    let inflags = rt_get_payload(P_FLAGS);
    var out = OUT_HIT;
    let m = sbt_material();
    let f = frame_new(h.ns);
    let wi = to_local(f, -d);
    if (params.flags & FLAG_AOVS) != 0u {
        set_v3(P_ALBEDO, bsdf_KIND_albedo(m, h.uv));
        set_v3(P_NORMAL, h.ns);
    }
    if (inflags & IN_SCATTER) == 0u {
        // Without scattering, P_PDF carries the hit distance (the aov integrator's depth).
        set_f(P_PDF, h.t);
        rt_set_payload(P_RNG, rng);
        rt_set_payload(P_FLAGS, out);
        return;
    }
    if SMOOTH && params.light_count > 0u && (inflags & IN_NO_NEE) == 0u {
        let u_sel = rng_next(&rng);
        let ls = sample_light(h.p, u_sel, rng_next2(&rng));
        if ls.pdf > 0.0 {
            let ev = bsdf_KIND_eval_sided(m, wi, to_local(f, ls.dir), h.uv);
            let mis = select(mis_weight(ls.pdf * params.frac_lum, ev.w * params.frac_bsdf)
                * params.weight_lum, 1.0, ls.delta);
            let c = ev.xyz * ls.weight * mis;
            if any(c > vec3<f32>(0.0)) {
                let so = rt_offset_ray(h.p, side(h.ng, ls.dir));
                set_v3(P_NEE, c);
                set_v3(P_SORIGIN, so);
                set_v3(P_SVEC, ls.target_p - so);
                out |= OUT_NEE;
            }
        }
    }
    let u1 = rng_next(&rng);
    let u2 = rng_next2(&rng);
    let s = bsdf_KIND_sample_sided(m, wi, h.uv, u1, u2);
    if s.pdf > 0.0 && any(s.weight > vec3<f32>(0.0)) && (inflags & IN_NO_BSDF) == 0u {
        let wo = normalize(to_world(f, s.wo));
        set_v3(P_WO, wo);
        set_v3(P_WEIGHT, s.weight);
        set_f(P_PDF, s.pdf);
        set_f(P_ETA, s.eta);
        set_v3(P_ORIGIN, rt_offset_ray(h.p, side(h.ng, wo)));
        out |= OUT_CONTINUE;
        // Dirac and null lobes (Mitsuba's Delta flag includes Null) skip MIS at the next
        // emitter hit.
        if s.delta != 0u {
            out |= OUT_DELTA;
        }
    }
    rt_set_payload(P_RNG, rng);
    rt_set_payload(P_FLAGS, out);
}
