//! Native (Rust closure) programs, this backend's own program API: helpers (a device,
//! buffers, structures, native programs, SBTs and a shared log that programs write into) and
//! the native side of the unwinding contract (`DeviceCalls::unwinding`).

use optik_api::*;
use optik_cpu::program::abi::{Bindings, DeviceCalls};
use optik_cpu::{CpuBackend, CpuDevice, CpuDeviceExt, NativeModuleDesc, NativeProgram};
use std::sync::{Arc, Mutex};

/// A device with helpers.
pub struct Kit {
    pub dev: CpuDevice,
}

/// A program from a closure.
pub fn program(f: impl Fn(&mut dyn DeviceCalls) + Send + Sync + 'static) -> NativeProgram {
    Arc::new(move |_: &Bindings<'_>, c: &mut dyn DeviceCalls| f(c))
}

/// One log entry: launch index, what, values.
pub type Entry = (u32, String, Vec<f64>);

/// What programs record, by launch index.
#[derive(Clone, Default)]
pub struct Log(pub Arc<Mutex<Vec<Entry>>>);

impl Log {
    /// Records `what` with values for the launch index `x`.
    pub fn put(&self, c: &dyn DeviceCalls, what: &str, values: &[f64]) {
        let x = c.launch_index()[0];
        self.0
            .lock()
            .unwrap()
            .push((x, what.to_string(), values.to_vec()));
    }

    /// Entries of launch index `x`, in the order they were written.
    pub fn of(&self, x: u32) -> Vec<(String, Vec<f64>)> {
        self.0
            .lock()
            .unwrap()
            .iter()
            .filter(|e| e.0 == x)
            .map(|e| (e.1.clone(), e.2.clone()))
            .collect()
    }

    /// Names of the entries of launch index `x`.
    pub fn names(&self, x: u32) -> Vec<String> {
        self.of(x).into_iter().map(|e| e.0).collect()
    }

    /// The first entry named `what` of launch index `x`.
    pub fn get(&self, x: u32, what: &str) -> Option<Vec<f64>> {
        self.of(x).into_iter().find(|e| e.0 == what).map(|e| e.1)
    }

    pub fn clear(&self) {
        self.0.lock().unwrap().clear();
    }
}

/// One SBT record: a group and its data.
pub struct Rec(pub ProgramGroup, pub Vec<u8>);

impl Rec {
    pub fn new(g: ProgramGroup) -> Rec {
        Rec(g, Vec::new())
    }
    pub fn with_u32(g: ProgramGroup, words: &[u32]) -> Rec {
        Rec(g, bytemuck::cast_slice(words).to_vec())
    }
}

/// A ray for `trace_ray`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: [f32; 3],
    pub dir: [f32; 3],
    pub tmin: f32,
    pub tmax: f32,
    pub time: f32,
    pub mask: u32,
    pub flags: u32,
    pub sbt_offset: u32,
    pub sbt_stride: u32,
    pub miss: u32,
}

impl Ray {
    pub fn new(origin: [f32; 3], dir: [f32; 3]) -> Ray {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
            time: 0.0,
            mask: 0xFF,
            flags: 0,
            sbt_offset: 0,
            sbt_stride: 1,
            miss: 0,
        }
    }
    pub fn time(self, time: f32) -> Ray {
        Ray { time, ..self }
    }
}

/// Traces `ray` against `handle` with `payload`.
pub fn trace_ray(c: &mut dyn DeviceCalls, handle: TraversableHandle, r: Ray, payload: &mut [u32]) {
    c.trace(
        handle.to_words(),
        r.origin,
        r.dir,
        r.tmin,
        r.tmax,
        r.time,
        r.mask,
        r.flags,
        r.sbt_offset,
        r.sbt_stride,
        r.miss,
        payload,
    );
}

impl Kit {
    pub fn new() -> Kit {
        Kit {
            dev: CpuBackend::with_threads(2).map(CpuDevice::new).unwrap(),
        }
    }

    pub fn buffer<T: bytemuck::Pod>(&self, data: &[T]) -> Buffer {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let b = self.dev.create_buffer(bytes.len().max(4) as u64).unwrap();
        self.dev.write_buffer(b, 0, bytes).unwrap();
        b
    }

    pub fn build(&self, options: AccelBuildOptions, inputs: &[BuildInput]) -> TraversableHandle {
        let a = self.dev.accel_build(&options, inputs).unwrap();
        self.dev.traversable_handle(a).unwrap()
    }

    /// An unindexed triangle structure with one record and `flags`.
    pub fn triangles(&self, vertices: &[[f32; 3]], flags: GeometryFlags) -> TraversableHandle {
        let vb = self.buffer(vertices);
        let input = TriangleArray::new(BufferView::new(vb), vertices.len() as u32, flags);
        self.build(
            AccelBuildOptions::default(),
            &[BuildInput::Triangles(input)],
        )
    }

    pub fn instances(&self, instances: &[Instance]) -> TraversableHandle {
        let ib = self.buffer(instances);
        let input = InstanceArray {
            instances: BufferView::new(ib),
            num_instances: instances.len() as u32,
        };
        self.build(
            AccelBuildOptions::default(),
            &[BuildInput::Instances(input)],
        )
    }

    pub fn module(&self, programs: Vec<(&str, NativeProgram)>) -> Module {
        self.module_with(programs, 8, false)
    }

    pub fn module_with(
        &self,
        programs: Vec<(&str, NativeProgram)>,
        payload_values: u32,
        throws: bool,
    ) -> Module {
        let desc = NativeModuleDesc {
            programs: programs
                .into_iter()
                .map(|(n, p)| (n.to_string(), p))
                .collect(),
            payload_values,
            attribute_values: 8,
            throws,
        };
        self.dev.create_native_module(desc).unwrap()
    }

    pub fn group(&self, desc: ProgramGroupDesc) -> ProgramGroup {
        self.dev.create_program_groups(&[desc]).unwrap()[0]
    }

    pub fn raygen(&self, m: Module, name: &str) -> ProgramGroup {
        self.group(ProgramGroupDesc::Raygen(ProgramRef::new(m, name)))
    }

    pub fn miss(&self, m: Module, name: &str) -> ProgramGroup {
        self.group(ProgramGroupDesc::Miss(Some(ProgramRef::new(m, name))))
    }

    pub fn hit(
        &self,
        m: Module,
        ch: Option<&str>,
        ah: Option<&str>,
        is: Option<&str>,
    ) -> ProgramGroup {
        self.hit_builtin(m, ch, ah, is, BuiltinIntersector::Triangle)
    }

    pub fn hit_builtin(
        &self,
        m: Module,
        ch: Option<&str>,
        ah: Option<&str>,
        is: Option<&str>,
        builtin: BuiltinIntersector,
    ) -> ProgramGroup {
        let r = |n: Option<&str>| n.map(|n| ProgramRef::new(m, n));
        self.group(ProgramGroupDesc::HitGroup {
            closest_hit: r(ch),
            any_hit: r(ah),
            intersection: r(is),
            builtin,
        })
    }

    pub fn pipeline(
        &self,
        options: PipelineCompileOptions,
        max_trace_depth: u32,
        groups: &[ProgramGroup],
    ) -> Pipeline {
        let link = PipelineLinkOptions {
            max_trace_depth,
            ..Default::default()
        };
        self.dev.create_pipeline(&options, &link, groups).unwrap()
    }

    fn records(&self, recs: &[Rec]) -> Option<SbtRegion> {
        if recs.is_empty() {
            return None;
        }
        let data = recs.iter().map(|r| r.1.len()).max().unwrap_or(0);
        let stride = (32 + data).div_ceil(16) * 16;
        let mut bytes = vec![0u8; stride * recs.len()];
        for (i, r) in recs.iter().enumerate() {
            let h = self.dev.sbt_record_pack_header(r.0).unwrap();
            bytes[i * stride..i * stride + 32].copy_from_slice(&h);
            bytes[i * stride + 32..i * stride + 32 + r.1.len()].copy_from_slice(&r.1);
        }
        let b = self.buffer(&bytes);
        Some(SbtRegion {
            buffer: b,
            offset: 0,
            stride: stride as u32,
            count: recs.len() as u32,
        })
    }

    pub fn sbt(
        &self,
        raygen: Rec,
        miss: &[Rec],
        hit: &[Rec],
        callables: &[Rec],
        exception: Option<Rec>,
    ) -> ShaderBindingTable {
        let single = |r: Rec| {
            let region = self.records(&[r]).unwrap();
            SbtRecord {
                buffer: region.buffer,
                offset: 0,
            }
        };
        ShaderBindingTable {
            raygen: single(raygen),
            exception: exception.map(single),
            miss: self.records(miss),
            hitgroup: self.records(hit),
            callables: self.records(callables),
        }
    }

    pub fn launch(&self, pipeline: Pipeline, sbt: &ShaderBindingTable, width: u32) {
        self.dev
            .launch(pipeline, &[], &[], sbt, LaunchSize::new(width, 1, 1))
            .unwrap();
    }
}

/// A quad of two triangles in the plane z = `z`, spanning [x0, x1] × [y0, y1], facing -z
/// (counter-clockwise seen from below, so rays going +z see its front).
pub fn quad(x0: f32, y0: f32, x1: f32, y1: f32, z: f32) -> Vec<[f32; 3]> {
    vec![
        [x0, y0, z],
        [x0, y1, z],
        [x1, y1, z],
        [x0, y0, z],
        [x1, y1, z],
        [x1, y0, z],
    ]
}

/// Native programs see `unwinding()` after a throw and return; the exception program runs
/// once and the launch index ends (without `USER`, a throw ends only the throwing program).
#[test]
fn user_exceptions_end_the_launch_index() {
    let _launches = crate::shared();
    let kit = Kit::new();
    let gas = kit.triangles(
        &quad(-1.0, -1.0, 1.0, 1.0, 5.0),
        GeometryFlags::DISABLE_ANYHIT,
    );
    let log = Log::default();
    let (l1, l2, l3, l4) = (log.clone(), log.clone(), log.clone(), log.clone());
    let m = kit.module_with(
        vec![
            (
                "raygen__main",
                program(move |c| {
                    let x = c.launch_index()[0];
                    if x == 0 {
                        c.throw_exception(42 | (1 << 31));
                        return;
                    }
                    trace_ray(c, gas, Ray::new([0.0; 3], [0.0, 0.0, 1.0]), &mut [x]);
                    if c.unwinding() {
                        return;
                    }
                    l1.put(c, "after", &[]);
                }),
            ),
            (
                "closesthit__main",
                program(move |c| {
                    l2.put(c, "ch", &[]);
                    if c.get_payload(0) == 1 {
                        c.throw_exception(7);
                    }
                }),
            ),
            (
                "exception__main",
                program(move |c| {
                    l3.put(
                        c,
                        "exception",
                        &[c.exception_code() as f64, c.sbt_data_u32(0) as f64],
                    )
                }),
            ),
            ("miss__main", program(move |c| l4.put(c, "miss", &[]))),
        ],
        1,
        true,
    );
    let rg = kit.raygen(m, "raygen__main");
    let hg = kit.hit(m, Some("closesthit__main"), None, None);
    let ex = kit.group(ProgramGroupDesc::Exception(ProgramRef::new(
        m,
        "exception__main",
    )));
    let p = kit.pipeline(PipelineCompileOptions::default(), 1, &[rg, hg, ex]);
    assert!(
        kit.dev
            .pipeline_features(p)
            .unwrap()
            .exceptions
            .contains(ExceptionFlags::USER)
    );
    let sbt = kit.sbt(
        Rec::new(rg),
        &[],
        &[Rec::new(hg)],
        &[],
        Some(Rec::with_u32(ex, &[77])),
    );
    kit.launch(p, &sbt, 3);
    assert_eq!(
        log.of(0),
        vec![("exception".to_string(), vec![42.0, 77.0])],
        "user codes keep 30 bits"
    );
    assert_eq!(
        log.of(1),
        vec![
            ("ch".to_string(), vec![]),
            ("exception".to_string(), vec![7.0, 77.0])
        ]
    );
    assert_eq!(log.names(2), vec!["ch", "after"]);
    // Without USER checks a throw does nothing but end the throwing program.
    let options = PipelineCompileOptions {
        exception_flags: Setting::Value(ExceptionFlags::NONE),
        ..Default::default()
    };
    let p = kit.pipeline(options, 1, &[rg, hg, ex]);
    log.clear();
    kit.launch(p, &sbt, 2);
    assert_eq!(log.names(0), Vec::<String>::new());
    assert_eq!(log.names(1), vec!["ch", "after"]);
}
