// Slab tests of four boxes at once and of one box (DESIGN.md §5).
//
// Lines marked `@conservative` widen the far distance by 1 + 2γ(3) (pbrt-v4, Embree's robust
// mode): the subtraction, the multiplication and the reciprocal each round once, so the
// computed near and far can each be off by γ(3); widening far by 2γ(3) means a box the ray
// touches is never missed. The plain test drops those lines and keeps the `@plain` ones.
// The test is closed: a box touched exactly at tmin or tmax is hit.

const _OPTIK_SLAB_WIDEN: f32 = 1.00000036;

struct _OptikBox4 {
    hit: vec4<bool>,
    tnear: vec4<f32>,
}

fn _optik_box4(r: _OptikSlabRay, lo_x: vec4<f32>, hi_x: vec4<f32>, lo_y: vec4<f32>, hi_y: vec4<f32>, lo_z: vec4<f32>, hi_z: vec4<f32>, tmin: f32, tmax: f32) -> _OptikBox4 {
    let ninf = vec4<f32>(-_optik_inf());
    let pinf = vec4<f32>(_optik_inf());
    let o = r.origin;
    let ax = (lo_x - vec4<f32>(o.x)) * r.inv.x;
    let bx = (hi_x - vec4<f32>(o.x)) * r.inv.x;
    let ay = (lo_y - vec4<f32>(o.y)) * r.inv.y;
    let by = (hi_y - vec4<f32>(o.y)) * r.inv.y;
    let az = (lo_z - vec4<f32>(o.z)) * r.inv.z;
    let bz = (hi_z - vec4<f32>(o.z)) * r.inv.z;
    let near_x = select(min(ax, bx), ninf, r.parallel.x);
    let near_y = select(min(ay, by), ninf, r.parallel.y);
    let near_z = select(min(az, bz), ninf, r.parallel.z);
    var far_x = select(max(ax, bx), pinf, r.parallel.x);
    var far_y = select(max(ay, by), pinf, r.parallel.y);
    var far_z = select(max(az, bz), pinf, r.parallel.z);
    far_x = far_x * _OPTIK_SLAB_WIDEN; // @conservative
    far_y = far_y * _OPTIK_SLAB_WIDEN; // @conservative
    far_z = far_z * _OPTIK_SLAB_WIDEN; // @conservative
    let in_x = vec4<bool>(!r.parallel.x) | ((vec4<f32>(o.x) >= lo_x) & (vec4<f32>(o.x) <= hi_x));
    let in_y = vec4<bool>(!r.parallel.y) | ((vec4<f32>(o.y) >= lo_y) & (vec4<f32>(o.y) <= hi_y));
    let in_z = vec4<bool>(!r.parallel.z) | ((vec4<f32>(o.z) >= lo_z) & (vec4<f32>(o.z) <= hi_z));
    let tn = max(max(near_x, near_y), max(near_z, vec4<f32>(tmin)));
    let tf = min(min(far_x, far_y), min(far_z, vec4<f32>(tmax)));
    return _OptikBox4((tn <= tf) & in_x & in_y & in_z, tn);
}

fn _optik_box1(r: _OptikSlabRay, lo: vec3<f32>, hi: vec3<f32>, tmin: f32, tmax: f32) -> bool {
    let a = (lo - r.origin) * r.inv;
    let b = (hi - r.origin) * r.inv;
    let near = select(min(a, b), vec3<f32>(-_optik_inf()), r.parallel);
    var far = select(max(a, b), vec3<f32>(_optik_inf()), r.parallel);
    far = far * _OPTIK_SLAB_WIDEN; // @conservative
    let inside = !r.parallel | ((r.origin >= lo) & (r.origin <= hi));
    let tn = max(max(near.x, near.y), max(near.z, tmin));
    let tf = min(min(far.x, far.y), min(far.z, tmax));
    return tn <= tf && all(inside);
}
