// optik shared WGSL: the built-in sphere intersector (DESIGN.md §3 "Shared WGSL", §5).
//
// Written once in the project: the wgpu megakernel includes this file, and the Vulkan backend
// compiles it into the intersection stage it uses for sphere build inputs. Pure functions
// only: no bindings and no device-API calls, every name prefixed `_optik`.

// Hit kinds the built-in primitives (spheres and curves) report: the triangle face kinds,
// so `rt_is_front_face_hit` means the same for every built-in primitive. A hit where the ray
// enters the surface is a front-face hit; a hit where it leaves (a ray starting inside a
// sphere) is a back-face hit.
const _OPTIK_HIT_KIND_FRONT_FACE: u32 = 0xFEu;
const _OPTIK_HIT_KIND_BACK_FACE: u32 = 0xFFu;

// The two roots of |origin + t direction - center|^2 = radius^2, as (t_near, t_far, 1.0), or
// (0, 0, 0) when the ray misses the sphere or the direction is zero. `direction` need not be
// normalised: t is in units of it, as for every optik primitive.
//
// The numerically stable form of Ray Tracing Gems ch. 7 (Haines, Guenther, Akenine-Moeller):
// - the discriminant in the Hearn-Baker form a (r^2 - |v|^2), v = f - (f.d / a) d, evaluated
//   as a (r - |v|)(r + |v|): the squared distance from the centre to the ray comes from a
//   vector difference, so small or distant spheres do not lose every significant bit to the
//   cancellation of b^2 - 4ac;
// - the roots in the Press form q = -(b' + sign(b') sqrt(disc)), t0 = c / q, t1 = q / a,
//   which does not cancel for the near root of a large sphere seen from close by.
fn _optik_sphere_roots(center: vec3<f32>, radius: f32, origin: vec3<f32>, direction: vec3<f32>) -> vec3<f32> {
    let a = dot(direction, direction);
    if !(a > 0.0) {
        return vec3<f32>(0.0);
    }
    let f = origin - center;
    let b = dot(f, direction);
    let v = f - (b / a) * direction;
    let lv = length(v);
    let disc = a * (radius - lv) * (radius + lv);
    if !(disc >= 0.0) {
        return vec3<f32>(0.0);
    }
    let c = dot(f, f) - radius * radius;
    let q = -(b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
    if q == 0.0 {
        // b == 0 and disc == 0: the origin lies on the sphere and the ray is tangent to it.
        return vec3<f32>(0.0, 0.0, 1.0);
    }
    let t0 = c / q;
    let t1 = q / a;
    return vec3<f32>(min(t0, t1), max(t0, t1), 1.0);
}

// The outward unit normal of a sphere at a point on (or near) its surface.
fn _optik_sphere_normal(center: vec3<f32>, radius: f32, p: vec3<f32>) -> vec3<f32> {
    return (p - center) / radius;
}
