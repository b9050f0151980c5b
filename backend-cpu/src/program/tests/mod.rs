//! Tests of the JIT: WGSL programs run against hand-written Rust with the same operation
//! order, compared bit for bit, and a recording `DeviceCalls` for the device API.

mod arena;
mod arith;
mod builtins;
mod cache;
mod control;
mod device;
mod errors;
mod float;
mod memory;
mod texture;

use super::abi::{Bindings, BoundBuffer, BoundResource, DeviceCalls, DeviceState};
use super::{DiskCache, JitModule, JitOptions};
use optik_api::ProgramSource;
use optik_core::frontend::CompiledModule;

/// Payload registers of test modules.
pub const PAYLOAD: u32 = 4;

/// Parses and checks `wgsl` with the front end.
pub fn front(wgsl: &str) -> CompiledModule {
    optik_core::frontend::compile(&ProgramSource::new("test.wgsl", wgsl), PAYLOAD)
        .unwrap_or_else(|e| panic!("front end rejected the test program: {e}"))
}

/// Options without the disk cache (tests of the cache set their own directory).
pub fn options() -> JitOptions {
    JitOptions {
        disk_cache: DiskCache::Disabled,
        ..JitOptions::default()
    }
}

/// Compiles `wgsl`.
pub fn jit(wgsl: &str) -> JitModule {
    JitModule::compile(&front(wgsl), &options()).unwrap_or_else(|e| panic!("JIT failed: {e}"))
}

/// Buffers of 32-bit words bound at bindings 1, 2, ... (binding 0 is `params`).
pub struct Buffers {
    pub words: Vec<Vec<u32>>,
    /// Bytes bound per buffer (defaults to the whole buffer).
    pub bound: Vec<usize>,
    pub params: Vec<u32>,
}

impl Buffers {
    /// Buffers with these contents, bound whole, and no params.
    pub fn new(words: Vec<Vec<u32>>) -> Self {
        let bound = words.iter().map(|w| w.len() * 4).collect();
        Self {
            words,
            bound,
            params: Vec::new(),
        }
    }

    /// The params and the buffers, bound at 0 and 1.. (pointing into `self`).
    fn resources(&mut self) -> Vec<BoundResource> {
        let mut resources = vec![BoundResource::Buffer(BoundBuffer {
            ptr: self.params.as_mut_ptr().cast(),
            len: self.params.len() * 4,
        })];
        for (w, &len) in self.words.iter_mut().zip(&self.bound) {
            resources.push(BoundResource::Buffer(BoundBuffer {
                ptr: w.as_mut_ptr().cast(),
                len,
            }));
        }
        resources
    }

    /// Runs `program` of `module` once with these buffers.
    pub fn run(&mut self, module: &JitModule, program: &str, calls: &mut dyn DeviceCalls) {
        let f = module
            .program(program)
            .unwrap_or_else(|| panic!("no program {program}"));
        let resources = self.resources();
        f.call(
            &Bindings {
                resources: &resources,
            },
            calls,
        );
    }

    /// [`Buffers::run`] through a context built once ([`ProgramFn::repeated`]), called
    /// `times` times.
    pub fn run_repeated(
        &mut self,
        module: &JitModule,
        program: &str,
        calls: &mut dyn DeviceCalls,
        times: usize,
    ) {
        let f = module
            .program(program)
            .unwrap_or_else(|| panic!("no program {program}"));
        let resources = self.resources();
        let bindings = Bindings {
            resources: &resources,
        };
        let prepared = module.prepare(&bindings);
        let mut call = f
            .repeated(&prepared, calls, std::ptr::null(), std::ptr::null(), None)
            .expect("bindings prepared for the program's module");
        for _ in 0..times {
            call.call(calls);
        }
    }
}

/// Runs `program` with `words` as buffers 1.. and a default mock; returns the buffers.
pub fn run(module: &JitModule, program: &str, words: Vec<Vec<u32>>) -> Vec<Vec<u32>> {
    let mut buffers = Buffers::new(words);
    buffers.run(module, program, &mut Mock::default());
    buffers.words
}

/// A small deterministic generator (xorshift64*).
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u32(&mut self) -> u32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 32) as u32
    }

    /// Integers with a third of them from the edge cases.
    pub fn int(&mut self) -> u32 {
        const EDGES: [u32; 10] = [
            0,
            1,
            u32::MAX,
            0x8000_0000,
            0x7fff_ffff,
            7,
            (-7i32) as u32,
            31,
            32,
            33,
        ];
        let r = self.next_u32();
        if r.is_multiple_of(3) {
            EDGES[(r / 3) as usize % EDGES.len()]
        } else {
            self.next_u32()
        }
    }

    /// Floats with a third of them from the edge cases.
    pub fn float(&mut self) -> f32 {
        const EDGES: [f32; 14] = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            f32::MIN,
            1e-40,
            3e9,
            -3e9,
            2.5,
        ];
        let r = self.next_u32();
        if r.is_multiple_of(3) {
            EDGES[(r / 3) as usize % EDGES.len()]
        } else {
            (self.next_u32() as i32 as f32) / 1e8
        }
    }
}

/// What a [`Mock`] was asked, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    Trace {
        handle: [u32; 2],
        origin: [f32; 3],
        direction: [f32; 3],
        tmin: f32,
        tmax: f32,
        time: f32,
        words: [u32; 5],
        payload: Vec<u32>,
    },
    SetPayload(u32, u32),
    Report(f32, u32, [u32; 8]),
    Ignore,
    Terminate,
    Throw(u32),
    DirectCall(u32, Vec<u32>),
    ContinuationCall(u32, Vec<u32>),
}

/// A recording `DeviceCalls` whose getters return fixed, distinct values.
#[derive(Default)]
pub struct Mock {
    pub events: Vec<Event>,
    pub payload: Vec<u32>,
    /// What `rt_trace` writes into the payload (added to each register).
    pub trace_adds: u32,
    /// Values offered as memory (`DeviceCalls::state`), if any.
    pub state: Option<Box<DeviceState>>,
    /// `unwinding()` answers true once a call that runs other programs (trace, callables,
    /// report) was made.
    pub unwind_after_calls: bool,
}

pub const OBJECT_TO_WORLD: [f32; 12] = [
    1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0,
];

impl DeviceCalls for Mock {
    fn launch_index(&self) -> [u32; 3] {
        [3, 4, 5]
    }
    fn launch_dimensions(&self) -> [u32; 3] {
        [640, 480, 1]
    }
    fn trace(
        &mut self,
        handle: [u32; 2],
        origin: [f32; 3],
        direction: [f32; 3],
        tmin: f32,
        tmax: f32,
        time: f32,
        mask: u32,
        flags: u32,
        sbt_offset: u32,
        sbt_stride: u32,
        miss_index: u32,
        payload: &mut [u32],
    ) {
        self.events.push(Event::Trace {
            handle,
            origin,
            direction,
            tmin,
            tmax,
            time,
            words: [mask, flags, sbt_offset, sbt_stride, miss_index],
            payload: payload.to_vec(),
        });
        for p in payload.iter_mut() {
            *p = p.wrapping_add(self.trace_adds);
        }
    }
    fn get_payload(&self, i: u32) -> u32 {
        self.payload.get(i as usize).copied().unwrap_or(0xdead)
    }
    fn set_payload(&mut self, i: u32, v: u32) {
        self.events.push(Event::SetPayload(i, v));
    }
    fn get_attribute(&self, i: u32) -> u32 {
        100 + i
    }
    fn report_intersection(&mut self, t: f32, hit_kind: u32, attributes: &[u32; 8]) -> bool {
        self.events.push(Event::Report(t, hit_kind, *attributes));
        let accepted = t < 10.0;
        if let (true, Some(state)) = (accepted, &mut self.state) {
            state.ray_tmax = t;
        }
        accepted
    }
    fn ignore_intersection(&mut self) {
        self.events.push(Event::Ignore);
    }
    fn terminate_ray(&mut self) {
        self.events.push(Event::Terminate);
    }
    fn world_ray_origin(&self) -> [f32; 3] {
        [1.0, 2.0, 3.0]
    }
    fn world_ray_direction(&self) -> [f32; 3] {
        [0.0, 0.0, -1.0]
    }
    fn object_ray_origin(&self) -> [f32; 3] {
        [4.0, 5.0, 6.0]
    }
    fn object_ray_direction(&self) -> [f32; 3] {
        [0.0, -1.0, 0.0]
    }
    fn ray_tmin(&self) -> f32 {
        0.001
    }
    fn ray_tmax(&self) -> f32 {
        1e30
    }
    fn ray_time(&self) -> f32 {
        0.25
    }
    fn ray_flags(&self) -> u32 {
        0x11
    }
    fn ray_mask(&self) -> u32 {
        0xfe
    }
    fn primitive_index(&self) -> u32 {
        42
    }
    fn sbt_gas_index(&self) -> u32 {
        7
    }
    fn instance_id(&self) -> u32 {
        1234
    }
    fn instance_index(&self) -> u32 {
        9
    }
    fn hit_kind(&self) -> u32 {
        0xfe
    }
    fn is_front_face_hit(&self) -> bool {
        true
    }
    fn triangle_barycentrics(&self) -> [f32; 2] {
        [0.25, 0.5]
    }
    fn triangle_vertices(&self) -> [[f32; 3]; 3] {
        [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]
    }
    fn sphere(&self) -> [f32; 4] {
        [1.0, 2.0, 3.0, 0.5]
    }
    fn curve_parameter(&self) -> f32 {
        0.75
    }
    fn object_to_world(&self) -> [f32; 12] {
        OBJECT_TO_WORLD
    }
    fn world_to_object(&self) -> [f32; 12] {
        OBJECT_TO_WORLD.map(|x| -x)
    }
    fn sbt_data_u32(&self, i: u32) -> u32 {
        1000 + i
    }
    fn direct_call(&mut self, index: u32, args: &mut [u32]) {
        self.events.push(Event::DirectCall(index, args.to_vec()));
        args[0] = args[0].wrapping_mul(2);
    }
    fn continuation_call(&mut self, index: u32, args: &mut [u32]) {
        self.events
            .push(Event::ContinuationCall(index, args.to_vec()));
        args[0] = args[0].wrapping_mul(3);
    }
    fn throw_exception(&mut self, code: u32) {
        self.events.push(Event::Throw(code));
    }
    fn exception_code(&self) -> i32 {
        -3
    }
    fn remaining_trace_depth(&self) -> u32 {
        5
    }
    fn unwinding(&self) -> bool {
        self.unwind_after_calls
            && self.events.iter().any(|e| {
                matches!(
                    e,
                    Event::Trace { .. }
                        | Event::DirectCall(..)
                        | Event::ContinuationCall(..)
                        | Event::Report(..)
                )
            })
    }
    fn state(&self) -> *const DeviceState {
        self.state
            .as_deref()
            .map_or(std::ptr::null(), |s| s as *const DeviceState)
    }
}
