// ex02: the smallest complete pipeline. A raygen program writes the course's test pattern
// (r = x mod 256, g = y mod 256, b = (x + y) mod 256) without tracing anything; the
// closest-hit and miss programs are empty, as in the course, which needs them for a valid SBT.
struct Params {
    frame_id: u32,
    width: u32,
    height: u32,
    pad: u32,
}
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> image: array<vec4<f32>>;

fn raygen__render_frame() {
    let ix = rt_launch_index().x;
    let iy = rt_launch_index().y;
    let r = f32(ix % 256u);
    let g = f32(iy % 256u);
    let b = f32((ix + iy) % 256u);
    image[iy * params.width + ix] = vec4<f32>(r, g, b, 255.0) / 255.0;
}

fn closesthit__radiance() {}

fn anyhit__radiance() {}

fn miss__radiance() {}
