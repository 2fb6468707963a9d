//! The GPU device: an adapter (a real GPU, or lavapipe's Vulkan on the CPU) with its own
//! limits, and the error type of the GPU path.
//!
//! wgpu reports validation and out-of-memory errors through a callback; they are collected
//! here and turned into [`GpuError`]s by [`GpuContext::check`], so a bad shader or a buffer
//! the adapter refuses is an error message, never a panic.

use std::sync::{Arc, Mutex};
use thiserror::Error;

/// Errors of the GPU path.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter was found (no GPU, and no software Vulkan such as lavapipe).
    #[error(
        "no GPU adapter found ({0}); install a Vulkan driver (on Debian/Ubuntu without a GPU: apt-get install mesa-vulkan-drivers) or use --cpu"
    )]
    NoAdapter(String),
    /// The device could not be opened.
    #[error("cannot open the GPU device: {0}")]
    Device(String),
    /// A buffer is larger than the adapter allows.
    #[error(
        "{what} needs {bytes} bytes, more than this adapter's limit of {limit} bytes per buffer binding"
    )]
    TooLarge {
        /// What did not fit.
        what: String,
        /// Bytes needed.
        bytes: u64,
        /// The adapter's limit.
        limit: u64,
    },
    /// The scene or settings need something the GPU path does not do.
    #[error("{0}")]
    Unsupported(String),
    /// wgpu reported an error (validation, out of memory, device lost).
    #[error("GPU error: {0}")]
    Wgpu(String),
    /// The tracer's shader modules did not link.
    #[error(transparent)]
    Shader(#[from] crate::shader::ShaderError),
}

/// An open device with its queue and what the adapter is.
pub struct GpuContext {
    /// The adapter.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's name, backend and type.
    pub info: wgpu::AdapterInfo,
    /// The limits the device was opened with (the adapter's own).
    pub limits: wgpu::Limits,
    errors: Arc<Mutex<Vec<String>>>,
}

impl GpuContext {
    /// Opens the best adapter (high performance preferred) with its own limits: wgpu's
    /// defaults would cap buffers at 256 MiB and storage buffers per stage at 8.
    /// `WGPU_BACKEND` (vulkan, gl) and `WGPU_ADAPTER_NAME` choose among several.
    pub fn new() -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        Self::open(&instance, None)
    }

    /// [`Self::new`] on `instance`, with an adapter that can present to `surface` if given.
    pub fn open(
        instance: &wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Self, GpuError> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: surface,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        // The adapter's own limits first; some drivers (GL through EGL) refuse a device
        // with every limit raised, so then wgpu's defaults with the adapter's buffer sizes.
        let own = adapter.limits();
        let fallback = wgpu::Limits {
            max_storage_buffer_binding_size: own.max_storage_buffer_binding_size,
            max_buffer_size: own.max_buffer_size,
            max_storage_buffers_per_shader_stage: own.max_storage_buffers_per_shader_stage,
            ..wgpu::Limits::downlevel_defaults()
        };
        let mut opened = None;
        let mut failures = Vec::new();
        for limits in [own, fallback] {
            match pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("svo-view"),
                required_limits: limits.clone(),
                ..Default::default()
            })) {
                Ok(dq) => {
                    opened = Some((dq, limits));
                    break;
                }
                Err(e) => failures.push(e.to_string()),
            }
        }
        let ((device, queue), limits) =
            opened.ok_or_else(|| GpuError::Device(failures.join("; then ")))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&errors);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        Ok(Self {
            adapter,
            device,
            queue,
            info,
            limits,
            errors,
        })
    }

    /// A one-line description of the adapter: name, backend, type.
    pub fn adapter_name(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.info.name, self.info.backend, self.info.device_type
        )
    }

    /// Whether the adapter runs on the CPU (lavapipe, llvmpipe).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// The errors wgpu reported since the last check, as one error.
    pub fn check(&self) -> Result<(), GpuError> {
        let mut v = self
            .errors
            .lock()
            .map_err(|_| GpuError::Wgpu("error sink poisoned".into()))?;
        if v.is_empty() {
            Ok(())
        } else {
            let msg = v.join("; ");
            v.clear();
            Err(GpuError::Wgpu(msg))
        }
    }

    /// The most bytes one storage buffer binding may have.
    pub fn binding_limit(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// Checks that a storage buffer of `bytes` fits one binding.
    pub fn fits(&self, what: &str, bytes: u64) -> Result<(), GpuError> {
        let limit = self.binding_limit();
        if bytes > limit {
            return Err(GpuError::TooLarge {
                what: what.to_string(),
                bytes,
                limit,
            });
        }
        Ok(())
    }

    /// Waits for the queue to finish its work.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Wgpu(e.to_string()))?;
        self.check()
    }
}
