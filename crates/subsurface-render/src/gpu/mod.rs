//! Headless GPU context: adapter selection from wgpu's usual environment variables, a device
//! with timestamp queries where available, and validation errors turned into `RenderError`s.

pub mod layout;
pub mod object;

use std::cell::RefCell;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use crate::error::{RenderError, one_line};

/// Held while this process creates or destroys a Vulkan instance or device. NVIDIA's Linux
/// driver is not thread-safe there (wgpu issues 5930 and 10010, blade issue 336): two test
/// threads that each made and dropped a context killed the test process with SIGSEGV on an
/// H200 (driver 580), while lavapipe never showed it. Contexts are made once per renderer,
/// so serialising their creation and teardown costs nothing measurable.
static DRIVER: Mutex<()> = Mutex::new(());

fn driver_lock() -> MutexGuard<'static, ()> {
    // The guarded data is `()`: a thread that panicked while holding it left nothing broken.
    DRIVER.lock().unwrap_or_else(PoisonError::into_inner)
}

thread_local! {
    /// The driver lock between [`TeardownBegin`] and [`TeardownEnd`]: fields drop in
    /// declaration order, so the wgpu handles declared between them drop while it is held.
    static TEARDOWN: RefCell<Option<MutexGuard<'static, ()>>> = const { RefCell::new(None) };
}

/// First field of [`GpuContext`]: takes the driver lock before its wgpu handles drop.
#[derive(Clone)]
struct TeardownBegin;

impl Drop for TeardownBegin {
    fn drop(&mut self) {
        let guard = driver_lock();
        TEARDOWN.with(|t| *t.borrow_mut() = Some(guard));
    }
}

/// Last field of [`GpuContext`]: releases the lock once its wgpu handles are gone.
#[derive(Clone)]
struct TeardownEnd;

impl Drop for TeardownEnd {
    fn drop(&mut self) {
        TEARDOWN.with(|t| t.borrow_mut().take());
    }
}

/// A wgpu device and queue that need no window. Share it between passes; clone is cheap.
#[derive(Clone)]
pub struct GpuContext {
    // Must stay the first field (see `TEARDOWN`).
    _teardown_begin: TeardownBegin,
    /// The wgpu instance the adapter came from (the viewer makes its surface with it).
    pub instance: wgpu::Instance,
    /// The adapter the device runs on.
    pub adapter: wgpu::Adapter,
    /// The device, with the adapter's own limits and timestamp queries where it has them.
    pub device: wgpu::Device,
    /// The device's queue.
    pub queue: wgpu::Queue,
    errors: Arc<Mutex<Vec<String>>>,
    // Must stay the last field.
    _teardown_end: TeardownEnd,
}

impl GpuContext {
    /// Creates a headless context. `WGPU_BACKEND` limits the backends, `WGPU_ADAPTER_NAME`
    /// picks an adapter by (case-insensitive) substring, `WGPU_POWER_PREF` is honoured too.
    pub fn new_headless() -> Result<Self, RenderError> {
        let _driver = driver_lock();
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(select_adapter(&instance))?;
        Self::with_device(instance, adapter)
    }

    /// Creates the device on a chosen adapter (used by the viewer, which needs a surface).
    pub fn from_adapter(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
    ) -> Result<Self, RenderError> {
        let _driver = driver_lock();
        Self::with_device(instance, adapter)
    }

    fn with_device(instance: wgpu::Instance, adapter: wgpu::Adapter) -> Result<Self, RenderError> {
        let info = adapter.get_info();
        // Timestamp queries give the per-pass GPU times that `render` and `bench` report; an
        // adapter without them still renders, it just reports no GPU times.
        // 32-bit depth with a stencil keeps the lighting pass's z-buffer as precise as the
        // others where the adapter has it (`lighting::zbuffer_format`).
        let required_features = adapter.features()
            & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::DEPTH32FLOAT_STENCIL8);
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("subsurface"),
            required_features,
            required_limits: limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| RenderError::Device {
            adapter: info.name.clone(),
            message: one_line(&e.to_string()),
        })?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        // wgpu's default handler panics; we collect instead and fail the operation that caused
        // the error (see `check`), so validation errors are failures that reach the caller.
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(one_line(&e.to_string()));
            }
        }));
        Ok(Self {
            _teardown_begin: TeardownBegin,
            instance,
            adapter,
            device,
            queue,
            errors,
            _teardown_end: TeardownEnd,
        })
    }

    /// "name (backend, device type)" of the adapter in use.
    pub fn adapter_name(&self) -> String {
        let i = self.adapter.get_info();
        format!("{} ({:?}, {:?})", i.name, i.backend, i.device_type)
    }

    /// True if the device records GPU timestamps.
    pub fn has_timestamps(&self) -> bool {
        self.device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Largest 2-D texture side the device accepts.
    pub fn max_texture_size(&self) -> u32 {
        self.device.limits().max_texture_dimension_2d
    }

    /// Waits for the GPU and returns the first validation error raised since the last check.
    pub fn check(&self) -> Result<(), RenderError> {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
        let mut errors = self.errors.lock().map_err(|_| {
            RenderError::Validation("error sink poisoned by an earlier panic".into())
        })?;
        if errors.is_empty() {
            Ok(())
        } else {
            let first = errors.remove(0);
            let more = errors.len();
            errors.clear();
            Err(RenderError::Validation(if more > 0 {
                format!("{first} (and {more} more)")
            } else {
                first
            }))
        }
    }

    /// Checks that a render-target size is usable on this device.
    pub fn check_size(&self, field: &str, width: u32, height: u32) -> Result<(), RenderError> {
        let max = self.max_texture_size();
        for (name, v) in [("width", width), ("height", height)] {
            if v == 0 || v > max {
                return Err(RenderError::invalid(
                    format!("{field}{name}"),
                    format!("must be in 1..={max} on this device (got {v})"),
                ));
            }
        }
        Ok(())
    }
}

async fn select_adapter(instance: &wgpu::Instance) -> Result<wgpu::Adapter, RenderError> {
    let env = |k: &str| std::env::var(k).unwrap_or_default();
    let wanted = env("WGPU_ADAPTER_NAME").to_lowercase();
    if !wanted.is_empty() {
        // wgpu's own helper panics when the name matches nothing; we want an error instead.
        for adapter in instance.enumerate_adapters(wgpu::Backends::all()).await {
            if adapter.get_info().name.to_lowercase().contains(&wanted) {
                return Ok(adapter);
            }
        }
    } else if let Ok(a) = instance
        .request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::from_env()
                .unwrap_or(wgpu::PowerPreference::HighPerformance),
            force_fallback_adapter: false,
            compatible_surface: None,
            apply_limit_buckets: false,
        })
        .await
    {
        return Ok(a);
    }
    Err(RenderError::NoAdapter {
        backend: env("WGPU_BACKEND"),
        name: env("WGPU_ADAPTER_NAME"),
    })
}

/// Whether the adapter runs the compute passes that write storage textures (the flux pyramid,
/// the transmitted map's compute evaluation, the workgroup SSS fetch): two storage textures per
/// stage and workgroups of 128 invocations with 4 KiB of shared memory.
pub fn supports_compute_storage(device: &wgpu::Device) -> bool {
    let l = device.limits();
    l.max_storage_textures_per_shader_stage >= 2
        && l.max_compute_invocations_per_workgroup >= 128
        && l.max_compute_workgroup_size_x >= 128
        && l.max_compute_workgroup_storage_size >= 4096
}
