//! The wgpu context: instance, adapter (reported by name, backend and driver), device and queue,
//! with timestamp queries enabled where the adapter has them.

use crate::error::GpuError;

/// A device ready for the shscale kernels.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// `TIMESTAMP_QUERY` is enabled (otherwise stages are timed by the synchronised wall clock).
    pub timestamps: bool,
}

/// Whether `SHSCALE_REQUIRE_GPU=1` is set (CI): tests that need an adapter fail instead of
/// skipping when none exists.
pub fn require_gpu_from_env() -> bool {
    std::env::var("SHSCALE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// `name (backend, driver driver_info)` of an adapter.
fn describe_info(i: &wgpu::AdapterInfo) -> String {
    let driver = [i.driver.as_str(), i.driver_info.as_str()]
        .iter()
        .filter(|s| !s.is_empty())
        .copied()
        .collect::<Vec<_>>()
        .join(" ");
    if driver.is_empty() {
        format!("{} ({:?})", i.name, i.backend)
    } else {
        format!("{} ({:?}, {driver})", i.name, i.backend)
    }
}

/// wgpu falls back to an OpenGL adapter when no Vulkan, Metal or DX12 driver is installed — on a
/// Linux machine without `mesa-vulkan-drivers` that is llvmpipe through GL, where a 24 × 24
/// two-frame render took 231 s (issue 57) and, measured on 2026-12-07 with Mesa 22.3.6, the
/// sphere sets' union images came out 0.54 of the mean irradiance from the CPU's
/// (`cli_run::budget_plane_times_the_gpu_path_beside_the_cpu`; 5e-7 through Vulkan lavapipe). shscale takes a GL adapter only
/// when asked: `WGPU_BACKEND` naming `gl` (e.g. `WGPU_BACKEND=gl`); otherwise it is refused
/// naming the adapter and both ways on, so `gpu = "auto"` continues on the CPU with that notice
/// and `gpu = "required"` fails. `described`: the adapter in words; `wgpu_backend`: the
/// variable's value.
pub(crate) fn check_backend(
    backend: wgpu::Backend,
    described: &str,
    wgpu_backend: Option<&str>,
) -> Result<(), GpuError> {
    let asked_for_gl = wgpu_backend.is_some_and(|v| {
        v.split(',').any(|b| {
            matches!(
                b.trim().to_ascii_lowercase().as_str(),
                "gl" | "gles" | "opengl"
            )
        })
    });
    if backend == wgpu::Backend::Gl && !asked_for_gl {
        return Err(GpuError::NoAdapter(format!(
            "the only adapter is {described}, wgpu's OpenGL fallback when no Vulkan driver is found, which shscale takes only when asked (WGPU_BACKEND=gl)"
        )));
    }
    Ok(())
}

impl GpuContext {
    /// The default adapter (`WGPU_BACKEND=vulkan|gl|…` selects a backend, as wgpu reads it).
    /// Without one: [`GpuError::NoAdapter`], never a panic.
    pub fn new() -> Result<Self, GpuError> {
        pollster::block_on(Self::new_async(true))
    }

    /// As [`GpuContext::new`], with timestamp queries left off even where the adapter has them
    /// (stages are then timed by the synchronised wall clock — the fallback path, testable on
    /// any adapter).
    pub fn without_timestamps() -> Result<Self, GpuError> {
        pollster::block_on(Self::new_async(false))
    }

    async fn new_async(want_timestamps: bool) -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        check_backend(
            info.backend,
            &describe_info(&info),
            std::env::var("WGPU_BACKEND").ok().as_deref(),
        )?;
        let timestamps =
            want_timestamps && adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let required_features = if timestamps {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        };
        // The adapter's own limits: the BSV ray buffer of large layouts exceeds the defaults'
        // 128 MiB only far beyond the sizes used here, but workgroup memory must reach 16 KiB.
        let required_limits = adapter.limits();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("shscale"),
                required_features,
                required_limits,
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(Self {
            device,
            queue,
            info,
            timestamps,
        })
    }

    /// `name (backend, driver driver_info)`, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, llvmpipe Mesa 22.3.6)`.
    pub fn describe(&self) -> String {
        describe_info(&self.info)
    }

    /// Block until all submitted work has finished.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Readback(e.to_string()))
    }

    /// A storage buffer initialised from `data` (`COPY_DST` too, so it can be rewritten).
    pub(crate) fn storage_init(&self, label: &str, data: &[u8]) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: data,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            })
    }

    /// `Ok` when a storage binding of `bytes` fits the adapter's limit, else an error naming
    /// `what` and both sizes (a buffer over the limit would fail in the driver, not here).
    pub fn check_binding(&self, what: &str, bytes: u64) -> Result<(), GpuError> {
        let max = self.device.limits().max_storage_buffer_binding_size;
        if bytes > max {
            return Err(GpuError::Input(format!(
                "{what} need {bytes} bytes, above the adapter's storage binding limit of {max}"
            )));
        }
        Ok(())
    }

    /// The first `n` receivers of an image buffer (`vec4<f32>` per receiver, RGB and a pad) as
    /// RGB, copied back to the host (blocking).
    pub fn read_image(&self, buffer: &wgpu::Buffer, n: usize) -> Result<Vec<[f32; 3]>, GpuError> {
        let raw: Vec<[f32; 4]> = bytemuck::cast_slice(&self.read_buffer(buffer)?).to_vec();
        Ok(raw[..n].iter().map(|p| [p[0], p[1], p[2]]).collect())
    }

    /// A uniform buffer holding `data`, rewritable (`COPY_DST`).
    pub fn uniform(&self, label: &str, data: &[u8]) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: data,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
    }

    /// An uninitialised storage buffer of `size` bytes (at least 16).
    pub fn storage(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    /// Copy `buffer` back to the host (blocking).
    pub(crate) fn read_buffer(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let size = buffer.size();
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.copy_and_map(buffer, &staging, size)
    }

    /// Copy the first `size` bytes of `buffer` into `staging` (a `MAP_READ | COPY_DST` buffer the
    /// caller keeps, so a per-frame readback makes none), wait, and read them back (blocking).
    pub(crate) fn copy_and_map(
        &self,
        buffer: &wgpu::Buffer,
        staging: &wgpu::Buffer,
        size: u64,
    ) -> Result<Vec<u8>, GpuError> {
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        enc.copy_buffer_to_buffer(buffer, 0, staging, 0, size);
        self.queue.submit([enc.finish()]);
        self.map_read(staging, size, wgpu::PollType::wait_indefinitely())
    }

    /// Read the first `size` bytes of `staging` (a `MAP_READ` buffer a copy in submission
    /// `index` filled) once that submission has completed — waiting for it alone, not for work
    /// submitted after it — then unmap it.
    pub(crate) fn map_after(
        &self,
        staging: &wgpu::Buffer,
        size: u64,
        index: wgpu::SubmissionIndex,
    ) -> Result<Vec<u8>, GpuError> {
        let wait = wgpu::PollType::Wait {
            submission_index: Some(index),
            timeout: None,
        };
        self.map_read(staging, size, wait)
    }

    /// Map the first `size` bytes of `staging` for reading, poll the device as `wait` says,
    /// copy them out and unmap.
    fn map_read(
        &self,
        staging: &wgpu::Buffer,
        size: u64,
        wait: wgpu::PollType,
    ) -> Result<Vec<u8>, GpuError> {
        let err = |e: &dyn std::fmt::Display| GpuError::Readback(e.to_string());
        let slice = staging.slice(..size);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device.poll(wait).map_err(|e| err(&e))?;
        rx.recv().map_err(|e| err(&e))?.map_err(|e| err(&e))?;
        let view = slice.get_mapped_range().map_err(|e| err(&e))?;
        let out = view.to_vec();
        drop(view);
        staging.unmap();
        Ok(out)
    }

    /// A compute pipeline from WGSL source with the automatic bind-group layout.
    pub fn pipeline(&self, label: &str, source: &str, entry: &str) -> wgpu::ComputePipeline {
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    /// A bind group for group 0 of `pipeline`, binding `buffers` at 0, 1, 2, …
    pub fn bind(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    }

    /// A bind group for group 0 of `pipeline` with each resource at its binding number (kernels
    /// of one module numbering their bindings across the module).
    pub(crate) fn bind_at(
        &self,
        pipeline: &wgpu::ComputePipeline,
        resources: &[(u32, wgpu::BindingResource<'_>)],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .iter()
            .map(|(binding, r)| wgpu::BindGroupEntry {
                binding: *binding,
                resource: r.clone(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    }
}

#[cfg(test)]
mod backend_tests {
    use super::check_backend;

    /// wgpu's GL fallback is refused unless `WGPU_BACKEND` asks for GL, naming the adapter and
    /// both ways on; every other backend is taken whatever the variable says.
    #[test]
    fn the_gl_fallback_is_taken_only_when_asked_for() {
        let gl = wgpu::Backend::Gl;
        let e = check_backend(gl, "llvmpipe (Gl)", None)
            .unwrap_err()
            .to_string();
        println!("{e}");
        assert!(
            e.contains("llvmpipe (Gl)") && e.contains("WGPU_BACKEND=gl"),
            "{e}"
        );
        assert!(check_backend(gl, "x", Some("vulkan")).is_err());
        for asked in ["gl", "GL", "vulkan,gl", " gles "] {
            assert!(check_backend(gl, "x", Some(asked)).is_ok(), "{asked}");
        }
        for b in [
            wgpu::Backend::Vulkan,
            wgpu::Backend::Metal,
            wgpu::Backend::Dx12,
        ] {
            assert!(check_backend(b, "x", None).is_ok());
            assert!(check_backend(b, "x", Some("gl")).is_ok());
        }
    }
}
