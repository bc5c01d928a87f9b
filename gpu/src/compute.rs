//! Buffers, compute dispatch and readback: the plumbing every kernel module uses.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use bytemuck::Pod;
use wgpu::util::DeviceExt;

use crate::context::Gpu;
use crate::error::GpuError;

/// Invocations per workgroup of every compute kernel (`WORKGROUP_SIZE` in `dispatch.wgsl`).
pub const WORKGROUP_SIZE: u32 = 64;

/// How long [`Gpu::read_back`] waits for the GPU (defined with the context, the layer below,
/// which also waits on submissions; re-exported here where the kernels' users look for it).
pub use crate::context::READBACK_TIMEOUT;

/// Upper bound on the items of one chunk of [`Gpu::run_per_item`] (4 Mi), so that a chunk's
/// buffers stay around a few hundred MB whatever the device allows.
pub const MAX_CHUNK_ITEMS: usize = 1 << 22;

/// WGSL shared by all compute kernels: `WORKGROUP_SIZE` and `linear_index`. Prepend it to a
/// kernel's source (WGSL has no includes).
pub const DISPATCH_WGSL: &str = include_str!("../shaders/dispatch.wgsl");

/// A compute pipeline built from WGSL, with its bind group layout inferred from the shader.
#[derive(Clone, Debug)]
pub struct ComputeKernel {
    pipeline: wgpu::ComputePipeline,
    label: String,
}

/// The dispatch grid [x, y] of workgroups for `count` invocations:
/// groups = ⌈count / 64⌉, x = min(groups, max_per_dimension), y = ⌈groups / x⌉. The shader
/// rebuilds the linear index as `gid.x + gid.y · x · 64` (`linear_index` in `dispatch.wgsl`)
/// and returns when it is ≥ count. [`GpuError::ExceedsLimit`] (naming `kernel`) when y exceeds
/// the limit too, i.e. more than max_per_dimension² workgroups.
pub fn workgroup_grid(
    kernel: &str,
    count: u32,
    max_per_dimension: u32,
) -> Result<[u32; 2], GpuError> {
    let groups = count.div_ceil(WORKGROUP_SIZE);
    if groups == 0 {
        return Ok([0, 0]);
    }
    let x = groups.min(max_per_dimension.max(1));
    let y = groups.div_ceil(x);
    if y > max_per_dimension {
        return Err(GpuError::ExceedsLimit {
            kernel: kernel.to_string(),
            limit: "max_compute_workgroups_per_dimension (squared: workgroups per dispatch)",
            needed: u64::from(groups),
            allowed: u64::from(max_per_dimension).pow(2),
        });
    }
    Ok([x, y])
}

/// The most invocations one dispatch can have when at most `max_per_dimension` workgroups fit
/// each dimension of the grid of [`workgroup_grid`]: max_per_dimension² · 64.
pub fn max_dispatch_items(max_per_dimension: u32) -> u64 {
    u64::from(max_per_dimension).pow(2) * u64::from(WORKGROUP_SIZE)
}

impl Gpu {
    /// The largest storage buffer a kernel can bind, in bytes:
    /// min(max_storage_buffer_binding_size, max_buffer_size).
    pub fn max_storage_bytes(&self) -> u64 {
        let l = self.limits();
        l.max_storage_buffer_binding_size.min(l.max_buffer_size)
    }

    /// [`GpuError::ExceedsLimit`] (naming `label`) unless a buffer of `bytes` bytes can be
    /// created (max_buffer_size; binding it whole needs [`Gpu::max_storage_bytes`], checked by
    /// [`Gpu::dispatch`]).
    pub(crate) fn check_buffer_size(&self, label: &str, bytes: u64) -> Result<(), GpuError> {
        let max = self.limits().max_buffer_size;
        if bytes > max {
            return Err(GpuError::ExceedsLimit {
                kernel: label.to_string(),
                limit: "max_buffer_size",
                needed: bytes,
                allowed: max,
            });
        }
        Ok(())
    }

    /// [`GpuError::ExceedsLimit`] (naming `kernel`) if a storage buffer is larger than a binding
    /// may be.
    fn check_binding_size(&self, kernel: &str, buffer: &wgpu::Buffer) -> Result<(), GpuError> {
        let max = self.limits().max_storage_buffer_binding_size;
        if buffer.usage().contains(wgpu::BufferUsages::STORAGE) && buffer.size() > max {
            return Err(GpuError::ExceedsLimit {
                kernel: kernel.to_string(),
                limit: "max_storage_buffer_binding_size",
                needed: buffer.size(),
                allowed: max,
            });
        }
        Ok(())
    }

    /// A storage buffer (STORAGE | COPY_SRC | COPY_DST) holding `data`. An empty slice gives one
    /// zeroed element, since a binding cannot be empty. [`Gpu::write_storage`] can overwrite it.
    pub fn upload_storage<T: Pod>(
        &self,
        label: &str,
        data: &[T],
    ) -> Result<wgpu::Buffer, GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let zero = vec![0u8; std::mem::size_of::<T>()];
        let contents = if bytes.is_empty() { &zero[..] } else { bytes };
        self.check_buffer_size(label, contents.len() as u64)?;
        Ok(self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
            }))
    }

    /// Overwrite the start of a buffer made by [`Gpu::upload_storage`] with `data` (queued; it
    /// takes effect before the next submitted dispatch).
    pub fn write_storage<T: Pod>(&self, buffer: &wgpu::Buffer, data: &[T]) {
        self.queue
            .write_buffer(buffer, 0, bytemuck::cast_slice(data));
    }

    /// A uniform buffer holding `value` (its size must be a multiple of 16 bytes to match a
    /// WGSL uniform struct).
    pub fn upload_uniform<T: Pod>(&self, label: &str, value: &T) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::bytes_of(value),
                usage: wgpu::BufferUsages::UNIFORM,
            })
    }

    /// A zeroed storage buffer (STORAGE | COPY_SRC) for `len` elements of `T` (at least one),
    /// for a kernel to write and [`Gpu::read_back`] to copy from.
    pub fn output_storage<T: Pod>(
        &self,
        label: &str,
        len: usize,
    ) -> Result<wgpu::Buffer, GpuError> {
        let bytes = (len.max(1) * std::mem::size_of::<T>()) as u64;
        self.check_buffer_size(label, bytes)?;
        Ok(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        }))
    }

    /// Compile `source` and build the compute pipeline of its entry point `entry`, with the
    /// bind group layout inferred from the shader, once per context (later calls with the same
    /// label, source and entry return the cached pipeline). Invalid WGSL gives
    /// [`GpuError::Validation`] with the compiler's message.
    pub fn compute_kernel(
        &self,
        label: &str,
        source: &str,
        entry: &str,
    ) -> Result<ComputeKernel, GpuError> {
        // One compilation per context: keyed by label, entry point and the source itself.
        let key = format!("compute\u{0}{label}\u{0}{entry}\u{0}{source}");
        self.cached(&key, || self.compile_kernel(label, source, entry))
    }

    fn compile_kernel(
        &self,
        label: &str,
        source: &str,
        entry: &str,
    ) -> Result<ComputeKernel, GpuError> {
        self.checked(|| {
            let module = self
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(label),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
            let pipeline = self
                .device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(label),
                    layout: None,
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                });
            Ok(ComputeKernel {
                pipeline,
                label: label.to_string(),
            })
        })
    }

    /// Run `kernel` over `count` invocations with `buffers[n]` bound at `@group(0)
    /// @binding(n)`, on the grid of [`workgroup_grid`], and submit. Does nothing for
    /// `count == 0`; [`GpuError::ExceedsLimit`] if a storage buffer exceeds the binding limit or
    /// the grid the workgroup limit (checked before wgpu sees anything).
    pub fn dispatch(
        &self,
        kernel: &ComputeKernel,
        buffers: &[&wgpu::Buffer],
        count: u32,
    ) -> Result<(), GpuError> {
        let [x, y] = workgroup_grid(
            &kernel.label,
            count,
            self.limits().max_compute_workgroups_per_dimension,
        )?;
        if x == 0 {
            return Ok(());
        }
        for buffer in buffers {
            self.check_binding_size(&kernel.label, buffer)?;
        }
        self.checked(|| {
            let entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .enumerate()
                .map(|(n, b)| wgpu::BindGroupEntry {
                    binding: n as u32,
                    resource: b.as_entire_binding(),
                })
                .collect();
            let bind_group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(&kernel.label),
                layout: &kernel.pipeline.get_bind_group_layout(0),
                entries: &entries,
            });
            let mut encoder = self.encoder(&kernel.label);
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(&kernel.label),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&kernel.pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
            self.submit(encoder.finish());
            Ok(())
        })
    }

    /// The most items of `item_bytes` bytes one chunk of [`Gpu::run_per_item`] may hold:
    /// min(max_storage_bytes / item_bytes, [`MAX_CHUNK_ITEMS`]).
    pub fn max_chunk_len(&self, item_bytes: usize) -> usize {
        let by_limit = self.max_storage_bytes() / item_bytes.max(1) as u64;
        (by_limit.min(MAX_CHUNK_ITEMS as u64) as usize).max(1)
    }

    /// Run a one-item-per-invocation `kernel` over `input`, `chunk_len` items at a time (fewer
    /// where the device's limits require: an input or output chunk is at most one storage
    /// binding, a dispatch at most [`max_dispatch_items`]; the split does not change the
    /// results). Per chunk: bind `[uniform params(count), shared…, input chunk, output chunk]`
    /// at bindings 0, 1, …, dispatch `count` invocations, read the output back; return all
    /// outputs in order.
    pub fn run_per_item<P: Pod, I: Pod, O: Pod>(
        &self,
        kernel: &ComputeKernel,
        params: impl Fn(u32) -> P,
        shared: &[&wgpu::Buffer],
        input: &[I],
        chunk_len: usize,
    ) -> Result<Vec<O>, GpuError> {
        let item_bytes = std::mem::size_of::<I>().max(std::mem::size_of::<O>());
        let per_dispatch =
            max_dispatch_items(self.limits().max_compute_workgroups_per_dimension).max(1);
        let chunk_len = chunk_len
            .min(self.max_chunk_len(item_bytes))
            .min(usize::try_from(per_dispatch).unwrap_or(usize::MAX))
            .max(1);
        let mut output = Vec::with_capacity(input.len());
        for chunk in input.chunks(chunk_len) {
            let count = u32::try_from(chunk.len())
                .map_err(|_| GpuError::TooLarge(format!("chunk of {} items", chunk.len())))?;
            let params = self.upload_uniform(&kernel.label, &params(count));
            let input = self.upload_storage(&kernel.label, chunk)?;
            let out = self.output_storage::<O>(&kernel.label, chunk.len())?;
            let mut buffers = vec![&params];
            buffers.extend_from_slice(shared);
            buffers.extend([&input, &out]);
            self.dispatch(kernel, &buffers, count)?;
            output.extend(self.read_back::<O>(&out, chunk.len())?);
        }
        Ok(output)
    }

    /// The first `len` elements of `T` of a storage buffer: copy to a mappable staging buffer,
    /// submit, wait (at most [`READBACK_TIMEOUT`]), map and copy out.
    pub fn read_back<T: Pod>(&self, buffer: &wgpu::Buffer, len: usize) -> Result<Vec<T>, GpuError> {
        if len == 0 {
            return Ok(Vec::new());
        }
        let size = (len * std::mem::size_of::<T>()) as u64;
        let (staging, submission) = self.checked(|| {
            let staging = self.staging_buffer("read_back", size);
            let mut encoder = self.encoder("read_back");
            encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
            let submission = self.queue.submit([encoder.finish()]);
            Ok((staging, submission))
        })?;
        let bytes = self.map_staging(&staging, submission)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// A MAP_READ | COPY_DST buffer of `size` bytes to copy results into.
    pub(crate) fn staging_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    pub(crate) fn encoder(&self, label: &str) -> wgpu::CommandEncoder {
        self.device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
    }

    /// Map `staging` for reading once `submission` (the copy into it) has completed and return
    /// its bytes. Waits with `device.poll(PollType::Wait { submission_index, timeout })`.
    pub(crate) fn map_staging(
        &self,
        staging: &wgpu::Buffer,
        submission: wgpu::SubmissionIndex,
    ) -> Result<Vec<u8>, GpuError> {
        let deadline = Instant::now() + READBACK_TIMEOUT;
        let (sender, receiver) = mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |result| {
            // The receiver lives until the mapping is resolved; a send error cannot happen.
            let _ = sender.send(result);
        });
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission),
                timeout: Some(READBACK_TIMEOUT),
            })
            .map_err(|e| match e {
                wgpu::PollError::Timeout => GpuError::Timeout,
                other => GpuError::Map(other.to_string()),
            })?;
        // The callback normally ran inside the wait above; keep polling in case another
        // thread's poll is delivering it.
        let mapped = loop {
            match receiver.try_recv() {
                Ok(result) => break result,
                Err(mpsc::TryRecvError::Disconnected) => {
                    return Err(GpuError::Map("the map callback was dropped".into()))
                }
                Err(mpsc::TryRecvError::Empty) if Instant::now() > deadline => {
                    return Err(GpuError::Timeout)
                }
                Err(mpsc::TryRecvError::Empty) => {
                    let _ = self.device.poll(wgpu::PollType::Poll);
                    std::thread::sleep(Duration::from_millis(1));
                }
            }
        };
        mapped.map_err(|e| GpuError::Map(e.to_string()))?;
        let bytes = staging
            .get_mapped_range(..)
            .map_err(|e| GpuError::Map(e.to_string()))?
            .to_vec();
        staging.unmap();
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn workgroup_grid_wraps_into_rows() {
        let grid = |count, max| workgroup_grid("k", count, max);
        assert_eq!(grid(0, 65535).unwrap(), [0, 0]);
        assert_eq!(grid(1, 65535).unwrap(), [1, 1]);
        assert_eq!(grid(64, 65535).unwrap(), [1, 1]);
        assert_eq!(grid(65, 65535).unwrap(), [2, 1]);
        // 70 000 workgroups: one full row and a partial second one.
        assert_eq!(grid(64 * 70_000, 65535).unwrap(), [65535, 2]);
        // The largest u32 count fits the 65535² grid of every WebGPU device.
        assert_eq!(grid(u32::MAX, 65535).unwrap(), [65535, 1025]);
        assert_eq!(grid(64 * 10 + 1, 4).unwrap(), [4, 3]);
        assert_eq!(max_dispatch_items(4), 64 * 16);
        assert_eq!(grid(64 * 16, 4).unwrap(), [4, 4]);
        let e = grid(64 * 16 + 1, 4).unwrap_err();
        assert_eq!(
            e,
            GpuError::ExceedsLimit {
                kernel: "k".into(),
                limit: "max_compute_workgroups_per_dimension (squared: workgroups per dispatch)",
                needed: 17,
                allowed: 16,
            }
        );
        assert_eq!(e.to_string().lines().count(), 1);
    }
}
