//! One timing procedure for GPU stages (docs/ARCHITECTURE.md (habit 10)): timestamp queries at the beginning and end
//! of every compute pass where the adapter supports `TIMESTAMP_QUERY`; otherwise each stage is
//! submitted on its own and timed by the wall clock between synchronisations. Warm-up, repeats and
//! medians are the caller's (the sequence module).

use crate::context::GpuContext;

use crate::error::GpuError;

/// Timestamp slots for `stages` compute passes.
pub struct StageTimer {
    stages: u32,
    queries: Option<(wgpu::QuerySet, wgpu::Buffer)>,
    /// A kept `MAP_READ` copy of the resolved timestamps ([`Self::resolve_to_staging`]).
    staging: Option<wgpu::Buffer>,
}

impl StageTimer {
    /// A timer for `stages` passes; timestamp-based when the context has them.
    pub fn new(ctx: &GpuContext, stages: u32) -> Self {
        let queries = ctx.timestamps.then(|| {
            let set = ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("stage timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * stages,
            });
            let buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: 16 * stages as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, buf)
        });
        let staging = ctx.timestamps.then(|| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp staging"),
                size: 16 * stages as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        Self {
            stages,
            queries,
            staging,
        }
    }

    /// Whether stages are timed by timestamps (else by the wall clock).
    pub(crate) fn uses_timestamps(&self) -> bool {
        self.queries.is_some()
    }

    /// Run the `S` stages named `labels` (at most the timer's), each recorded into its own
    /// compute pass by `record(i, pass)`, and wait: their device seconds — by timestamps in one
    /// submission where the context has them, else each stage submitted alone and timed by the
    /// synchronised wall clock.
    pub fn run<const S: usize>(
        &self,
        ctx: &GpuContext,
        labels: [&str; S],
        record: impl Fn(usize, &mut wgpu::ComputePass<'_>),
    ) -> Result<[f64; S], GpuError> {
        assert!(
            S as u32 <= self.stages,
            "more stages than the timer was made for"
        );
        let encoder = || {
            ctx.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
        };
        let mut device = [0.0; S];
        if self.uses_timestamps() {
            let mut enc = encoder();
            for (i, label) in labels.iter().enumerate() {
                record(i, &mut enc.begin_compute_pass(&self.pass(label, i as u32)));
            }
            self.resolve(&mut enc);
            ctx.queue.submit([enc.finish()]);
            ctx.wait()?;
            let s = self.read(ctx)?.expect("timestamps enabled");
            device.copy_from_slice(&s[..S]);
        } else {
            for (i, d) in device.iter_mut().enumerate() {
                let t = std::time::Instant::now();
                let mut enc = encoder();
                record(
                    i,
                    &mut enc.begin_compute_pass(&self.pass(labels[i], i as u32)),
                );
                ctx.queue.submit([enc.finish()]);
                ctx.wait()?;
                *d = t.elapsed().as_secs_f64();
            }
        }
        Ok(device)
    }

    /// The pass descriptor of stage `i`, with its timestamp writes when available.
    pub fn pass<'a>(&'a self, label: &'a str, i: u32) -> wgpu::ComputePassDescriptor<'a> {
        wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: self.queries.as_ref().map(|(set, _)| {
                wgpu::ComputePassTimestampWrites {
                    query_set: set,
                    beginning_of_pass_write_index: Some(2 * i),
                    end_of_pass_write_index: Some(2 * i + 1),
                }
            }),
        }
    }

    /// Record the resolve of all timestamps (after the last pass).
    pub fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        if let Some((set, buf)) = &self.queries {
            enc.resolve_query_set(set, 0..2 * self.stages, buf, 0);
        }
    }

    /// Seconds per stage from the resolved timestamps (after the submission has completed), or
    /// `None` without timestamps.
    pub fn read(&self, ctx: &GpuContext) -> Result<Option<Vec<f64>>, GpuError> {
        let (Some((_, buf)), Some(staging)) = (&self.queries, &self.staging) else {
            return Ok(None);
        };
        // Into the timer's own staging buffer: a frame reads its timestamps without allocating.
        Ok(Some(self.seconds(
            ctx,
            &ctx.copy_and_map(buf, staging, buf.size())?,
        )))
    }

    /// Record the resolve of all timestamps and their copy into the timer's staging buffer,
    /// for [`Self::read_after`] (frames in flight: nothing waits for the submission).
    pub fn resolve_to_staging(&self, enc: &mut wgpu::CommandEncoder) {
        self.resolve(enc);
        if let (Some((_, buf)), Some(staging)) = (&self.queries, &self.staging) {
            enc.copy_buffer_to_buffer(buf, 0, staging, 0, buf.size());
        }
    }

    /// Seconds per stage of a frame resolved by [`Self::resolve_to_staging`] in submission
    /// `index`, once that submission alone has completed; `None` without timestamps.
    pub fn read_after(
        &self,
        ctx: &GpuContext,
        index: wgpu::SubmissionIndex,
    ) -> Result<Option<Vec<f64>>, GpuError> {
        let Some(staging) = &self.staging else {
            return Ok(None);
        };
        let bytes = ctx.map_after(staging, staging.size(), index)?;
        Ok(Some(self.seconds(ctx, &bytes)))
    }

    /// Each stage's end minus its start, in seconds.
    fn seconds(&self, ctx: &GpuContext, bytes: &[u8]) -> Vec<f64> {
        let ticks: &[u64] = bytemuck::cast_slice(bytes);
        let period_ns = ctx.queue.get_timestamp_period() as f64;
        (0..self.stages as usize)
            .map(|i| ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * period_ns * 1e-9)
            .collect()
    }
}

/// Workgroup counts `(x, y)` covering `n` invocations of a 64-wide workgroup within the 65 535
/// per-dimension limit; kernels index `(wg.y · nwg.x + wg.x) · 64 + local`.
pub(crate) fn grid_64(n: u32) -> (u32, u32) {
    let groups = n.div_ceil(64).max(1);
    let x = groups.min(65_535);
    (x, groups.div_ceil(x))
}

/// Median of a non-empty list.
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_every_invocation_and_respects_the_limit() {
        for n in [1u32, 63, 64, 65, 4_194_240, 4_194_304, 10_000_000] {
            let (x, y) = grid_64(n);
            assert!(x <= 65_535 && y <= 65_535, "{n}: {x}×{y}");
            assert!(x as u64 * y as u64 * 64 >= n as u64, "{n}: {x}×{y}");
            // No more than one partial row of workgroups beyond what is needed.
            assert!((x as u64 * (y as u64 - 1)) * 64 < n as u64, "{n}: {x}×{y}");
        }
    }

    #[test]
    fn median_of_odd_and_even_lists() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
    }
}
