//! The oracle: an independent brute-force `f64` tracer (no BVH) with exact orientation
//! predicates, which runs each case's program models and says, per launch index, which
//! records are admissible.
//!
//! It shares no intersection code with the backends; it uses `optik_api::semantics` for the
//! rules that are the specification (flag precedence, SBT index math, facing, motion
//! interpolation, the invalid-ray policy).

pub mod choice;
pub mod exact;
pub mod exec;
pub mod geometry;
pub mod math;
pub mod model;
pub mod prepared;

use crate::case::{Case, ParamWord, RecordLayout};
use choice::Chooser;
use exec::{Buffers, Engine, ExecState, Order, Settings};
use optik::ExceptionFlags;

/// Most runs of one launch index (ambiguity sequences) before the oracle stops enumerating.
pub const MAX_RUNS: usize = 4096;

/// What the oracle expects of one launch.
#[derive(Clone, Debug)]
pub struct Expectation {
    /// Image width and height (launch width × height·depth, or the buffer layout's).
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Per pixel, the admissible records (record words); the first is canonical.
    pub admissible: Vec<Vec<Vec<u32>>>,
    /// Per pixel, why it is ambiguous (empty when it is not).
    pub reasons: Vec<Vec<&'static str>>,
    /// Per pixel, whether enumeration stopped at [`MAX_RUNS`].
    pub truncated: Vec<bool>,
}

impl Expectation {
    /// Number of ambiguous pixels.
    pub fn ambiguous_count(&self) -> usize {
        self.admissible.iter().filter(|a| a.len() > 1).count()
    }
}

/// The settings a case's pipeline implies.
pub fn settings(case: &Case, order: Order) -> Settings {
    let p = &case.pipeline;
    let auto_exceptions = if p.exception.is_some() {
        ExceptionFlags::STACK_OVERFLOW | ExceptionFlags::TRACE_DEPTH | ExceptionFlags::USER
    } else {
        ExceptionFlags::NONE
    };
    Settings {
        order,
        exceptions: p.compile.exception_flags.or(auto_exceptions),
        motion: p
            .compile
            .uses_motion_blur
            .or(prepared::has_motion(&case.scene)),
        max_trace_depth: p.link.max_trace_depth,
        payload_len: p.compile.num_payload_values.or(32) as usize,
        rounding: case.rounding,
    }
}

/// The launch parameter words as the oracle's models see them.
pub fn params_words(params: &[ParamWord]) -> Vec<u32> {
    params
        .iter()
        .map(|w| match *w {
            ParamWord::U32(v) => v,
            ParamWord::F32(f) => f.to_bits(),
            ParamWord::HandleLo(n) => prepared::handle_words(n)[0],
            ParamWord::HandleHi(n) => prepared::handle_words(n)[1],
        })
        .collect()
}

/// The buffer writes of one run: ((binding, word), value), sorted.
type Writes = Vec<((u32, usize), u32)>;

/// Runs one launch index through every ambiguity sequence; returns the distinct overlays
/// (writes) and why it was ambiguous.
fn run_index(
    engine: &Engine<'_>,
    buffers: &Buffers,
    params: &[u32],
    index: [u32; 3],
    dims: [u32; 3],
) -> Result<(Vec<Writes>, Vec<&'static str>, bool), String> {
    let mut chooser = Chooser::new();
    let mut outcomes: Vec<Writes> = Vec::new();
    let mut runs = 0;
    loop {
        let mut st = ExecState::new(&mut chooser, buffers, params, index, dims);
        engine.run_index(&mut st)?;
        if let Some(bad) = st.bad_access.take() {
            return Err(format!(
                "launch index {index:?}: the model makes a {bad} outside the buffers"
            ));
        }
        let mut writes: Vec<((u32, usize), u32)> = st.overlay.into_iter().collect();
        writes.sort();
        if !outcomes.contains(&writes) {
            outcomes.push(writes);
        }
        runs += 1;
        if runs >= MAX_RUNS {
            return Ok((outcomes, chooser.reasons().to_vec(), true));
        }
        if !chooser.next_run() {
            return Ok((outcomes, chooser.reasons().to_vec(), false));
        }
    }
}

/// The oracle's expectation for every launch of `case`.
///
/// Real traversals visit candidates in no fixed order, so the case is evaluated nearest-first
/// and farthest-first. Where the oracle admits a single record either way, the two must agree
/// (otherwise the case itself depends on traversal order, which is an error); where a record is
/// ambiguous, both orders' records are admissible.
pub fn expect(case: &Case) -> Result<Vec<Expectation>, String> {
    let up = expect_in_order(case, Order::Ascending)?;
    let down = expect_in_order(case, Order::Descending)?;
    up.into_iter()
        .zip(down)
        .enumerate()
        .map(|(k, (mut a, b))| {
            for i in 0..a.admissible.len() {
                let (ra, rb) = (&mut a.admissible[i], &b.admissible[i]);
                if ra.len() == 1 && rb.len() == 1 && ra[0] != rb[0] {
                    return Err(format!(
                        "launch {k}, record {i} depends on the traversal order: nearest-first gives {:?}, farthest-first {:?}",
                        ra[0], rb[0]
                    ));
                }
                for r in rb {
                    if !ra.contains(r) {
                        ra.push(r.clone());
                    }
                }
                a.truncated[i] |= b.truncated[i];
                for reason in &b.reasons[i] {
                    if !a.reasons[i].contains(reason) {
                        a.reasons[i].push(reason);
                    }
                }
                if a.admissible[i].len() > 1 && a.reasons[i].is_empty() {
                    a.reasons[i].push("traversal order");
                }
            }
            Ok(a)
        })
        .collect()
}

/// The oracle's expectation for every launch of `case`, visiting candidates in `order`.
pub fn expect_in_order(case: &Case, order: Order) -> Result<Vec<Expectation>, String> {
    case.scene.check()?;
    let engine = Engine::new(case, prepared::prepare(&case.scene), settings(case, order));
    let rec = &case.record;
    case.launches
        .iter()
        .enumerate()
        .map(|(k, launch)| {
            let params = params_words(&launch.params);
            let buffers: Buffers = launch.buffers.iter().map(|b| (b.binding, b.words.clone())).collect();
            let base = buffers
                .get(&rec.binding)
                .ok_or_else(|| format!("launch {k} has no record buffer at binding {}", rec.binding))?
                .clone();
            let [w, h, d] = launch.dims;
            let count = launch.count();
            match rec.layout {
                RecordLayout::PerIndex { stride } => {
                    if base.len() < count * stride {
                        return Err(format!("launch {k}: the record buffer holds {} words, {count} records need {}", base.len(), count * stride));
                    }
                    let mut e = Expectation {
                        width: w as usize,
                        height: (h * d) as usize,
                        admissible: Vec::with_capacity(count),
                        reasons: Vec::with_capacity(count),
                        truncated: Vec::with_capacity(count),
                    };
                    for i in 0..count {
                        let index = [i as u32 % w, (i as u32 / w) % h, i as u32 / (w * h)];
                        let (outcomes, reasons, truncated) = run_index(&engine, &buffers, &params, index, launch.dims)?;
                        let slot = i * stride..(i + 1) * stride;
                        // Only the recorded words matter: outcomes that differ elsewhere are
                        // the same outcome for judging.
                        let recorded: Vec<bool> = (0..stride).map(|w| rec.channels.iter().any(|c| c.word == w)).collect();
                        let mut records: Vec<Vec<u32>> = Vec::new();
                        for writes in outcomes {
                            let mut r = base[slot.clone()].to_vec();
                            for ((b, word), v) in writes {
                                if b != rec.binding || !slot.contains(&word) {
                                    return Err(format!(
                                        "launch {k}, index {index:?}: the model writes word {word} of binding {b}, outside its record (words {slot:?} of binding {})",
                                        rec.binding
                                    ));
                                }
                                r[word - slot.start] = v;
                            }
                            for (w, keep) in r.iter_mut().zip(&recorded) {
                                if !keep {
                                    *w = 0;
                                }
                            }
                            if !records.contains(&r) {
                                records.push(r);
                            }
                        }
                        e.admissible.push(records);
                        e.reasons.push(reasons);
                        e.truncated.push(truncated);
                    }
                    Ok(e)
                }
                RecordLayout::WholeBuffer { width } => {
                    let mut words = base.clone();
                    for i in 0..count {
                        let index = [i as u32 % w, (i as u32 / w) % h, i as u32 / (w * h)];
                        let (outcomes, _, _) = run_index(&engine, &buffers, &params, index, launch.dims)?;
                        if outcomes.len() > 1 {
                            return Err(format!("launch {k}, index {index:?}: a whole-buffer record cannot hold an ambiguous launch index"));
                        }
                        for ((b, word), v) in outcomes.into_iter().flatten() {
                            if b == rec.binding {
                                words[word] = v;
                            }
                        }
                    }
                    let n = words.len();
                    Ok(Expectation {
                        width,
                        height: n.div_ceil(width.max(1)),
                        admissible: words.into_iter().map(|v| vec![vec![v]]).collect(),
                        reasons: vec![Vec::new(); n],
                        truncated: vec![false; n],
                    })
                }
            }
        })
        .collect()
}
