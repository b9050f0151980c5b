struct Params { n: u32, scale: f32, pad0: u32, pad1: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

var<private> acc: f32;

fn helper(x: f32, k: u32) -> f32 {
    var s = x;
    for (var i = 0u; i < k; i++) {
        s = s * 0.5 + f32(i);
        if s > 100.0 { break; }
    }
    return s;
}

fn raygen__loops() {
    let id = rt_launch_index();
    var total = 0u;
    var i = 0u;
    loop {
        if i >= params.n { break; }
        total += i * id.x;
        i += 1u;
        continuing {
            acc += 1.0;
        }
    }
    var j = 10;
    while j > 0 {
        j -= 3;
        switch j {
            case 1, 2: { total ^= 7u; }
            case 4: { continue; }
            default: { total += u32(j); }
        }
    }
    let v = helper(params.scale, id.y % 8u);
    let m = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, v, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    let r = m * vec3<f32>(acc, 2.0, 3.0);
    out[id.x % arrayLength(&out)] = total + u32(r.y) + bitcast<u32>(sqrt(abs(r.z)));
}
