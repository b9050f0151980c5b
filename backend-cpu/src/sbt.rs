//! Reading a launch's shader binding table: every record's header is checked and resolved
//! to a program group of the pipeline before any program runs.

use crate::pipeline::{Callable, GroupObject, GroupPrograms, PipelineObject, PreparedModules};
use optik_api::sbt::SBT_RECORD_HEADER_SIZE;
use optik_api::{Buffer, DeviceId, GroupRegion, Result, SbtRegion, ShaderBindingTable};

/// The programs of a record's group, ready to call.
#[derive(Clone, Copy, Default)]
pub(crate) struct RecordPrograms<'l> {
    /// Raygen, miss, exception or closest-hit program.
    pub main: Option<Callable<'l>>,
    pub any_hit: Option<Callable<'l>>,
    pub intersection: Option<Callable<'l>>,
    pub direct: Option<Callable<'l>>,
    pub continuation: Option<Callable<'l>>,
}

impl<'l> RecordPrograms<'l> {
    fn of(p: &'l GroupPrograms, prepared: &'l PreparedModules<'l>) -> Result<RecordPrograms<'l>> {
        let c = |x: &'l Option<crate::pipeline::ProgramCode>| {
            x.as_ref().map(|c| c.callable(prepared)).transpose()
        };
        Ok(RecordPrograms {
            main: c(&p.main)?,
            any_hit: c(&p.any_hit)?,
            intersection: c(&p.intersection)?,
            direct: c(&p.direct)?,
            continuation: c(&p.continuation)?,
        })
    }
}

/// One record: its group's programs and its data (the bytes after the header).
pub(crate) struct Record<'l> {
    pub programs: RecordPrograms<'l>,
    pub data: Vec<u8>,
    /// Whether `programs.main` exists and does something: asked once here rather than per
    /// trace (most camera rays miss, and a miss program that keeps the payload is common).
    pub main_runs: bool,
}

impl<'l> Record<'l> {
    fn new(programs: RecordPrograms<'l>, data: Vec<u8>) -> Record<'l> {
        let main_runs = programs.main.is_some_and(|p| !p.does_nothing());
        Record {
            programs,
            data,
            main_runs,
        }
    }
}

impl Record<'_> {
    /// Word `i` of the record's data (zero past its end).
    #[inline]
    pub fn data_u32(&self, i: u32) -> u32 {
        let at = i as usize * 4;
        match self.data.get(at..at + 4) {
            Some(b) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            None => 0,
        }
    }
}

/// The resolved table.
pub(crate) struct ResolvedSbt<'l> {
    pub raygen: Record<'l>,
    pub exception: Option<Record<'l>>,
    pub miss: Vec<Record<'l>>,
    pub hitgroup: Vec<Record<'l>>,
    pub callables: Vec<Record<'l>>,
    /// What a hit whose record index lies past `hitgroup` uses: no programs, no data.
    pub null_hit: Record<'l>,
}

/// Reads records out of buffers.
pub(crate) trait RecordBytes {
    /// The bytes of `buffer` (already checked by `validate::sbt`).
    fn buffer(&self, buffer: Buffer) -> Result<&[u8]>;
}

struct Reader<'a, 'l> {
    device: DeviceId,
    pipeline: &'l PipelineObject,
    prepared: &'l PreparedModules<'l>,
    bytes: &'a dyn RecordBytes,
    max_data: usize,
}

impl<'l> Reader<'_, 'l> {
    fn record(
        &self,
        what: &str,
        buffer: Buffer,
        offset: u64,
        data_len: usize,
        region: GroupRegion,
    ) -> Result<Record<'l>> {
        let bytes = self.bytes.buffer(buffer).map_err(|e| e.context(what))?;
        let group: &'l GroupObject = optik_core::sbt::resolve_record_header(
            what,
            bytes,
            offset,
            region,
            self.device,
            |h| {
                self.pipeline
                    .groups
                    .iter()
                    .find(|(g, _)| optik_api::Handle::raw(g) == h)
                    .map(|(_, g)| g.as_ref())
            },
        )?;
        let start = offset as usize;
        let data_start = start + SBT_RECORD_HEADER_SIZE as usize;
        let data_end = (data_start + data_len.min(self.max_data)).min(bytes.len());
        Ok(Record::new(
            RecordPrograms::of(&group.programs, self.prepared)?,
            bytes[data_start..data_end].to_vec(),
        ))
    }

    fn region(
        &self,
        what: &str,
        region: &Option<SbtRegion>,
        kind: GroupRegion,
    ) -> Result<Vec<Record<'l>>> {
        let Some(r) = region else {
            return Ok(Vec::new());
        };
        (0..r.count)
            .map(|i| {
                let offset = r.offset + i as u64 * r.stride as u64;
                let data = r.stride.saturating_sub(SBT_RECORD_HEADER_SIZE) as usize;
                self.record(&format!("{what} record {i}"), r.buffer, offset, data, kind)
            })
            .collect()
    }
}

/// Resolves every record of `table` (whose shape `validate::sbt` checked) against the
/// pipeline's groups; programs are called with the bindings `prepared` holds.
pub(crate) fn resolve<'l>(
    table: &ShaderBindingTable,
    device: DeviceId,
    pipeline: &'l PipelineObject,
    prepared: &'l PreparedModules<'l>,
    bytes: &dyn RecordBytes,
    max_record_stride: u32,
) -> Result<ResolvedSbt<'l>> {
    let max_data = max_record_stride.saturating_sub(SBT_RECORD_HEADER_SIZE) as usize;
    let r = Reader {
        device,
        pipeline,
        prepared,
        bytes,
        max_data,
    };
    // Single records have no stride: their data runs to the end of the buffer (capped).
    let raygen = r.record(
        "sbt.raygen",
        table.raygen.buffer,
        table.raygen.offset,
        usize::MAX,
        GroupRegion::Raygen,
    )?;
    let exception = table
        .exception
        .map(|e| {
            r.record(
                "sbt.exception",
                e.buffer,
                e.offset,
                usize::MAX,
                GroupRegion::Exception,
            )
        })
        .transpose()?;
    Ok(ResolvedSbt {
        raygen,
        exception,
        miss: r.region("sbt.miss", &table.miss, GroupRegion::Miss)?,
        hitgroup: r.region("sbt.hitgroup", &table.hitgroup, GroupRegion::HitGroup)?,
        callables: r.region("sbt.callables", &table.callables, GroupRegion::Callables)?,
        null_hit: Record::new(RecordPrograms::default(), Vec::new()),
    })
}
