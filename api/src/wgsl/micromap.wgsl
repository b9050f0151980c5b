// Opacity micromaps: the micro-triangle a hit falls in and its state (OptiX/Vulkan
// encoding: 0 transparent, 1 opaque, 2 unknown-transparent, 3 unknown-opaque).
//
// Micro-triangles are numbered along the hierarchical "bird" curve of OptiX and Vulkan: at
// subdivision level L there are 4^L, and micro-triangle i at level L is a child of
// micro-triangle i >> 2 at level L − 1. `_optik_micro_triangle` gives the corners of one
// from its index (the discrete-barycentric form of the curve); `_optik_micro_index` descends
// the levels to the micro-triangle holding barycentrics (u, v). Points on a shared edge go
// to the child that comes first along the curve.

fn _optik_even_bits(x0: u32) -> u32 {
    var x = x0 & 0x55555555u;
    x = (x | (x >> 1u)) & 0x33333333u;
    x = (x | (x >> 2u)) & 0x0F0F0F0Fu;
    x = (x | (x >> 4u)) & 0x00FF00FFu;
    return (x | (x >> 8u)) & 0x0000FFFFu;
}

fn _optik_suffix_xor(x0: u32) -> u32 {
    var x = x0;
    x = x ^ (x >> 1u);
    x = x ^ (x >> 2u);
    x = x ^ (x >> 4u);
    x = x ^ (x >> 8u);
    return x;
}

// Micro-triangle `index` at `level`: its right-angle corner (u, v) and the signed length of
// its legs (positive when upright, along +u and +v; negative when inverted).
fn _optik_micro_triangle(index: u32, level: u32) -> vec3<f32> {
    if level == 0u {
        return vec3<f32>(0.0, 0.0, 1.0);
    }
    let b0 = _optik_even_bits(index);
    let b1 = _optik_even_bits(index >> 1u);
    let fx = _optik_suffix_xor(b0);
    let fy = _optik_suffix_xor(b0 & ~b1);
    let t = fy ^ b1;
    let du = (fx & ~t) | (b0 & ~t) | (~b0 & ~fx & t);
    let dv = fy ^ b0;
    let dw = (~fx & ~t) | (b0 & ~t) | (~b0 & fx & t);
    let mask = (1u << level) - 1u;
    var iu = du & mask;
    var iv = dv & mask;
    let upright = ((iu ^ iv ^ (dw & mask)) & 1u) != 0u;
    if !upright {
        iu = iu + 1u;
        iv = iv + 1u;
    }
    let s = 1.0 / f32(1u << level);
    return vec3<f32>(f32(iu) * s, f32(iv) * s, select(-s, s, upright));
}

fn _optik_micro_index(u_in: f32, v_in: f32, level: u32) -> u32 {
    let u = clamp(u_in, 0.0, 1.0);
    let v = clamp(v_in, 0.0, 1.0 - u);
    var parent = 0u;
    for (var l = 1u; l <= level; l = l + 1u) {
        // The child containing (u, v); failing that (rounding), the one it is least outside.
        var chosen = 4u * parent;
        var least_outside = _optik_inf();
        for (var j = 0u; j < 4u; j = j + 1u) {
            let c = _optik_micro_triangle(4u * parent + j, l);
            let a = (u - c.x) / c.z;
            let b = (v - c.y) / c.z;
            let outside = max(max(-a, -b), a + b - 1.0);
            if outside < least_outside {
                least_outside = outside;
                chosen = 4u * parent + j;
                if outside <= 0.0 {
                    break;
                }
            }
        }
        parent = chosen;
    }
    return parent;
}

// The byte at `byte_index` of a byte array packed into vec4<u32> words from `base`.
fn _optik_fetch_byte(base: u32, byte_index: u32) -> u32 {
    let v = _optik_fetch(base + byte_index / 16u);
    let word = v[(byte_index / 4u) % 4u];
    return (word >> (8u * (byte_index % 4u))) & 0xFFu;
}

// The state at (u, v) of a micromap whose states start at byte `byte_offset` of the data at
// `data_base`, with `level` and `four_state` (else two-state).
fn _optik_micromap_state(data_base: u32, byte_offset: u32, level: u32, four_state: bool, u: f32, v: f32) -> u32 {
    let i = _optik_micro_index(u, v, level);
    if four_state {
        return (_optik_fetch_byte(data_base, byte_offset + i / 4u) >> (2u * (i % 4u))) & 3u;
    }
    return (_optik_fetch_byte(data_base, byte_offset + i / 8u) >> (i % 8u)) & 1u;
}
