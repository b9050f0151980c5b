// optik_api::semantics::opacity::resolve in WGSL: the fate of a candidate, 0 culled, 1 opaque,
// 2 non-opaque. `geometry`, `instance` and `ray` are the geometry, instance and ray flags;
// `state` is the candidate's micromap state (0..3), any other value (4, or _OPTIK_NONE) when
// it has none.
fn _optik_fate(geometry: u32, instance: u32, ray: u32, state: u32) -> u32 {
    let force_2_state = (ray & 1024u) != 0u || (instance & 16u) != 0u;
    var opaque = (geometry & 1u) != 0u;
    if state < 4u && (instance & 32u) == 0u {
        if state == 0u || (state == 2u && force_2_state) {
            return 0u;
        }
        opaque = state == 1u || (state == 3u && force_2_state);
    }
    if (instance & 4u) != 0u {
        opaque = true;
    } else if (instance & 8u) != 0u {
        opaque = false;
    }
    if (ray & 1u) != 0u {
        opaque = true;
    } else if (ray & 2u) != 0u {
        opaque = false;
    }
    if (opaque && (ray & 64u) != 0u) || (!opaque && (ray & 128u) != 0u) {
        return 0u;
    }
    return select(2u, 1u, opaque);
}
