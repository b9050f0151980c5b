// Ray/sphere test of the software traversal: the numerically stable quadratic of Ray
// Tracing Gems ch. 7 (Hearn–Baker discriminant, Numerical Recipes roots). Hits lie in the
// open interval (tmin, tmax). A ray from outside hits the near side (`front`); a ray that
// starts inside hits the far side from within (`front` false).

struct OptkSphereHit {
    hit: bool,
    t: f32,
    front: bool,
}

fn optk_sphere(o: vec3<f32>, d: vec3<f32>, centre: vec3<f32>, radius: f32, tmin: f32, tmax: f32) -> OptkSphereHit {
    let miss = OptkSphereHit(false, 0.0, false);
    let a = dot(d, d);
    if a == 0.0 {
        return miss;
    }
    let f = o - centre;
    let b = dot(f, d);
    let c = dot(f, f) - radius * radius;
    // b² − a·c without cancellation: a·(r² − |f⊥|²), f⊥ the part of f across the ray.
    let across = f - (b / a) * d;
    let disc = a * (radius * radius - dot(across, across));
    if disc < 0.0 {
        return miss;
    }
    let q = -(b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
    var t0 = 0.0;
    var t1 = 0.0;
    if q != 0.0 {
        t0 = q / a;
        t1 = c / q;
    }
    let near = min(t0, t1);
    let far = max(t0, t1);
    if near > tmin && near < tmax {
        return OptkSphereHit(true, near, true);
    }
    if far > tmin && far < tmax {
        return OptkSphereHit(true, far, false);
    }
    return miss;
}
