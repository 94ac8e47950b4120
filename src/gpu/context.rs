//! wgpu instance, adapter and device: works on Mesa lavapipe (CI) and on real
//! GPUs through Vulkan.
//!
//! Adapter choice: `STRANDFIT_ADAPTER` (a case-insensitive substring of the
//! adapter name, e.g. `llvmpipe` or `nvidia`, or its index in
//! `strandfit gpu-info`) overrides the default preference discrete >
//! integrated > virtual > CPU. Limits are the adapter's own (lavapipe:
//! 128 MiB per storage binding, 65535 workgroups per dimension), and every
//! dispatch is chunked to respect them.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::dispatch::{compile, Compiled};
pub use crate::kernels::{GpuError, ADAPTER_ENV};
use crate::kernels::{Kernel, Precision};
use crate::twin::Real;

/// One opened GPU.
pub struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    f64: bool,
    /// Every kernel compiled on this device, by name, configuration and
    /// precision: each is compiled once.
    pipelines: Mutex<HashMap<String, Arc<Compiled>>>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.info.name)
            .field("f64", &self.f64)
            .finish()
    }
}

fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    wgpu::Instance::new(desc)
}

fn type_rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

/// Names of all adapters the Vulkan backend sees, in index order.
pub fn list_adapters() -> Vec<wgpu::AdapterInfo> {
    pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN))
        .iter()
        .map(|a| a.get_info())
        .collect()
}

impl GpuContext {
    /// Open the adapter chosen by `STRANDFIT_ADAPTER`, or the best one.
    pub fn new() -> Result<Self, GpuError> {
        let wanted = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty());
        Self::with_adapter(wanted.as_deref())
    }

    /// Open the adapter whose name contains `wanted` (case-insensitive) or
    /// whose index is `wanted`; `None`: the best available.
    pub fn with_adapter(wanted: Option<&str>) -> Result<Self, GpuError> {
        let adapters = pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN));
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        let adapter = match wanted {
            Some(w) => {
                let wl = w.to_lowercase();
                let by_index = w.parse::<usize>().ok().and_then(|i| adapters.get(i));
                by_index
                    .or_else(|| {
                        adapters
                            .iter()
                            .find(|a| a.get_info().name.to_lowercase().contains(&wl))
                    })
                    .ok_or_else(|| GpuError::AdapterNotFound {
                        wanted: w.to_string(),
                        available: adapters
                            .iter()
                            .enumerate()
                            .map(|(i, a)| format!("[{i}] {}", a.get_info().name))
                            .collect::<Vec<_>>()
                            .join(", "),
                    })?
            }
            None => adapters
                .iter()
                .min_by_key(|a| type_rank(a.get_info().device_type))
                .expect("non-empty"),
        };
        let info = adapter.get_info();
        let f64 = adapter.features().contains(wgpu::Features::SHADER_F64);
        let features = if f64 {
            wgpu::Features::SHADER_F64
        } else {
            wgpu::Features::empty()
        };
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("strandfit"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            reason: e.to_string(),
        })?;
        Ok(GpuContext {
            device,
            queue,
            info,
            limits,
            f64,
            pipelines: Mutex::new(HashMap::new()),
        })
    }

    /// Adapter name, type and driver, for logs.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {}{})",
            self.info.name,
            self.info.device_type,
            self.info.driver,
            if self.info.driver_info.is_empty() {
                String::new()
            } else {
                format!(" {}", self.info.driver_info)
            }
        )
    }

    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// `f64` where the adapter has it, else `f32`.
    pub fn best_precision(&self) -> Precision {
        if self.f64 {
            Precision::F64
        } else {
            Precision::F32
        }
    }

    /// `K` compiled in configuration `cfg` and precision `R`: from the
    /// cache, or compiled now and kept.
    pub(crate) fn compiled<K: Kernel, R: Real>(
        &self,
        cfg: K::Config,
    ) -> Result<Arc<Compiled>, GpuError> {
        let key = format!("{}/{:?}/{}", K::NAME, cfg, R::WGSL);
        if let Some(k) = self.cache().get(&key) {
            return Ok(k.clone());
        }
        // Compiled outside the lock: another thread may compile the same
        // kernel meanwhile, and the first one kept wins.
        let k = Arc::new(compile::<K, R>(self, cfg)?);
        Ok(self.cache().entry(key).or_insert(k).clone())
    }

    fn cache(&self) -> std::sync::MutexGuard<'_, HashMap<String, Arc<Compiled>>> {
        self.pipelines.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Whether kernels can be compiled in `f64` (`SHADER_F64`).
    pub fn supports_f64(&self) -> bool {
        self.f64
    }

    /// Largest storage buffer binding, bytes.
    pub fn max_binding_bytes(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// Largest workgroup count per dispatch dimension.
    pub fn max_groups_per_dim(&self) -> u32 {
        self.limits.max_compute_workgroups_per_dimension
    }
}
