//! Triangles end to end: hits, misses, facing, barycentrics, the open t interval.

use crate::common::*;
use optik_api::*;

struct Rig {
    dev: Box<dyn Device>,
    pipeline: Pipeline,
    table: ShaderBindingTable,
    handle: TraversableHandle,
}

/// A RAY_LIST pipeline over one GAS of `vertices`, with the device's accuracy set first.
fn rig(vertices: &[[f32; 3]], accuracy: Accuracy) -> Rig {
    let dev = device();
    dev.set_accuracy(accuracy).unwrap();
    let gas = triangles(dev.as_ref(), vertices, GeometryFlags::NONE);
    let m = module(dev.as_ref(), RAY_LIST);
    let g = ray_list_groups(dev.as_ref(), m, 1, &[]);
    let pipeline = pipeline(dev.as_ref(), &g, 1);
    let table = numbered_sbt(dev.as_ref(), &g);
    let handle = dev.traversable_handle(gas).unwrap();
    Rig {
        dev,
        pipeline,
        table,
        handle,
    }
}

impl Rig {
    fn trace(&self, rays: &[Ray], args: TraceArgs) -> Vec<Rec> {
        trace_rays(
            self.dev.as_ref(),
            self.pipeline,
            &self.table,
            self.handle,
            rays,
            args,
        )
    }
}

#[test]
fn both_accuracy_settings_find_the_same_clear_hits() {
    let grid: Vec<[f32; 3]> = (0..8)
        .flat_map(|i| quad(i as f32, i as f32 + 1.0, 0.0, 1.0, i as f32 * 0.1))
        .collect();
    for accuracy in [Accuracy::ROBUST, Accuracy::FAST] {
        let r = rig(&grid, accuracy);
        let rays: Vec<Ray> = (0..32)
            .map(|k| Ray::new([k as f32 * 0.25 + 0.1, 0.4, 5.0], [0.0, 0.0, -1.0]))
            .collect();
        let recs = r.trace(&rays, TraceArgs::default());
        for (k, rec) in recs.iter().enumerate() {
            assert!(rec.hit(), "{accuracy:?} ray {k}");
            let cell = (k as f32 * 0.25 + 0.1).floor();
            assert!(
                (rec.t() - (5.0 - cell * 0.1)).abs() < 1e-5,
                "{accuracy:?} ray {k}: t {}",
                rec.t()
            );
            assert_eq!(rec.prim() / 2, cell as u32);
        }
    }
}
