//! Textures sampled by programs in a three-dimensional launch: every index reads the texel
//! its x selects and writes where its (x, y, z) says.

use optik::*;
use optik_conformance::kit::rig::*;

#[test]
fn textures_are_sampled_in_three_dimensional_launches() {
    on_every_backend("launch: textures in a 3D launch", |_, d| {
        let tex = d
            .create_texture(&TextureDesc {
                width: 2,
                height: 1,
                format: TextureFormat::R32Float,
            })
            .unwrap();
        d.write_texture(tex, bytemuck::cast_slice(&[0.25f32, 0.75]))
            .unwrap();
        let m = module(
            d,
            r#"
struct Params { handle: vec2<u32>, pad: vec2<u32> }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var tex: texture_2d<f32>;
@group(0) @binding(3) var smp: sampler;
fn raygen__r() {
    let i = rt_launch_index();
    let n = rt_launch_dimensions();
    let k = (i.z * n.y + i.y) * n.x + i.x;
    let s = textureSampleLevel(tex, smp, vec2<f32>((f32(i.x) + 0.5) / 2.0, 0.5), 0.0).x;
    out[k] = u32(s * 100.0) + 1000u * (i.x + 10u * i.y + 100u * i.z);
}
fn miss__m() { }
"#,
        );
        let g = groups(d, &[raygen(m, "raygen__r"), miss(m, "miss__m")]);
        let p = pipeline(d, &g, 1);
        let table = sbt(d, &g, &[]);
        let out = d.create_buffer(2 * 3 * 2 * 4).unwrap();
        d.launch(
            p,
            &[0u8; 16],
            &[
                Resource::buffer(1, out),
                Resource::Texture {
                    binding: 2,
                    texture: tex,
                },
                Resource::Sampler {
                    binding: 3,
                    sampler: SamplerDesc::default(),
                },
            ],
            &table,
            LaunchSize::new(2, 3, 2),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let r: Vec<u32> = read(d, out);
        for z in 0..2 {
            for y in 0..3 {
                for x in 0..2 {
                    let k = (z * 3 + y) * 2 + x;
                    assert_eq!(
                        r[k as usize],
                        [25, 75][x as usize] + 1000 * (x + 10 * y + 100 * z),
                        "index ({x}, {y}, {z})"
                    );
                }
            }
        }
    });
}
