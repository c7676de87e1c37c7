//! Adapter and device acquisition: hardware adapters before software ones, optional features
//! only where offered, limits clamped to the adapter's.

use std::fmt;

use crate::GpuError;

/// The timestamp-query features, requested by default wherever the adapter offers them:
/// pass timestamps (`TIMESTAMP_QUERY`), `write_timestamp` on encoders
/// (`TIMESTAMP_QUERY_INSIDE_ENCODERS`) and inside passes (`TIMESTAMP_QUERY_INSIDE_PASSES`).
pub const TIMESTAMP_FEATURES: wgpu::Features = wgpu::Features::TIMESTAMP_QUERY
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS)
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES);

/// Which adapters may serve a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdapterChoice {
    /// Only hardware adapters (discrete, integrated, virtual or unknown-type GPUs).
    HardwareOnly,
    /// Hardware adapters first, then software ones (CPU rasterisers such as lavapipe).
    HardwareThenSoftware,
}

impl fmt::Display for AdapterChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            AdapterChoice::HardwareOnly => "a hardware adapter",
            AdapterChoice::HardwareThenSoftware => "a hardware adapter, then a software one",
        })
    }
}

/// What a device is asked for.
#[derive(Clone, Debug)]
pub struct DeviceRequest {
    /// The device's label.
    pub label: &'static str,
    /// Features the device must have: adapters without them are passed over.
    pub required_features: wgpu::Features,
    /// Features requested where the adapter offers them (the device gets the intersection).
    pub optional_features: wgpu::Features,
    /// Limits asked for, each clamped to what the adapter offers: the device may get less
    /// (read [`GpuInfo::limits`]).
    pub limits: wgpu::Limits,
}

impl Default for DeviceRequest {
    /// No required features, the timestamp features where offered, wgpu's default limits.
    fn default() -> Self {
        DeviceRequest {
            label: "blurlab",
            required_features: wgpu::Features::empty(),
            optional_features: TIMESTAMP_FEATURES,
            limits: wgpu::Limits::default(),
        }
    }
}

/// The adapter behind a device and what the device was granted.
#[derive(Clone, Debug)]
pub struct GpuInfo {
    /// Adapter name (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
    pub name: String,
    /// Backend (Vulkan, Metal, Dx12, Gl).
    pub backend: wgpu::Backend,
    /// Driver name.
    pub driver: String,
    /// Driver version or description.
    pub driver_info: String,
    /// Device type as the driver reports it.
    pub device_type: wgpu::DeviceType,
    /// Whether it rasterises on the CPU ([`wgpu::DeviceType::Cpu`] or a known software
    /// renderer's name).
    pub is_software: bool,
    /// Features the device was created with.
    pub features: wgpu::Features,
    /// Limits the device was created with.
    pub limits: wgpu::Limits,
}

impl GpuInfo {
    /// `"NAME (BACKEND)"`, the short form benchmarks record.
    pub fn short(&self) -> String {
        format!("{} ({:?})", self.name, self.backend)
    }
}

impl fmt::Display for GpuInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = if self.is_software { "software" } else { "hardware" };
        write!(
            f,
            "{} ({:?}, {kind} {:?}, driver {} {})",
            self.name, self.backend, self.device_type, self.driver, self.driver_info
        )
    }
}

/// A device, its queue and what it is.
#[derive(Clone, Debug)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter and what the device was granted.
    pub info: GpuInfo,
}

impl GpuContext {
    /// [`crate::read_buffer`] on this device.
    pub fn read_buffer(
        &self,
        buffer: &wgpu::Buffer,
        range: impl std::ops::RangeBounds<u64>,
    ) -> Result<Vec<u8>, GpuError> {
        crate::read_buffer(&self.device, &self.queue, buffer, range)
    }

    /// [`crate::read_buffer_as`] on this device.
    pub fn read_buffer_as<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        range: impl std::ops::RangeBounds<u64>,
    ) -> Result<Vec<T>, GpuError> {
        crate::read_buffer_as(&self.device, &self.queue, buffer, range)
    }

    /// [`crate::read_texture`] on this device.
    pub fn read_texture(&self, texture: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
        crate::read_texture(&self.device, &self.queue, texture)
    }

    /// A [`crate::GpuTimer`] on this device.
    pub fn timer(&self) -> crate::GpuTimer {
        crate::GpuTimer::new(&self.device, &self.queue)
    }
}

/// Names of software rasterisers that some drivers report with another device type.
const SOFTWARE_NAMES: [&str; 5] = ["llvmpipe", "lavapipe", "softpipe", "swiftshader", "microsoft basic render"];

fn is_software(info: &wgpu::AdapterInfo) -> bool {
    let name = info.name.to_lowercase();
    info.device_type == wgpu::DeviceType::Cpu || SOFTWARE_NAMES.iter().any(|s| name.contains(s))
}

/// The order adapters are tried in (lower first): hardware by type, then software; within
/// a type, Vulkan, Metal, Dx12, then GL.
fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let kind = if is_software(info) {
        4
    } else {
        match info.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other | wgpu::DeviceType::Cpu => 3,
        }
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan => 0,
        wgpu::Backend::Metal => 1,
        wgpu::Backend::Dx12 => 2,
        wgpu::Backend::Gl => 3,
        _ => 4,
    };
    (kind, backend)
}

/// The instance every acquisition uses: backends and flags from the environment
/// (`WGPU_BACKEND`, ...), as the runner's window does.
fn instance() -> (wgpu::Instance, wgpu::Backends) {
    let descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    let backends = descriptor.backends;
    (wgpu::Instance::new(descriptor), backends)
}

/// The adapters the environment's instance finds, in the order [`acquire`] tries them.
pub fn adapter_infos() -> Vec<wgpu::AdapterInfo> {
    let (instance, backends) = instance();
    let mut infos: Vec<wgpu::AdapterInfo> =
        pollster::block_on(instance.enumerate_adapters(backends)).iter().map(wgpu::Adapter::get_info).collect();
    infos.sort_by_key(rank);
    infos
}

/// Features `wanted` cut to what `offered` has, keeping the timestamp features' dependencies
/// (inside-encoder timestamps need pass timestamps; inside-pass ones need both).
fn grantable(wanted: wgpu::Features, offered: wgpu::Features) -> wgpu::Features {
    let mut features = wanted & offered;
    if !features.contains(wgpu::Features::TIMESTAMP_QUERY) {
        features.remove(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);
    }
    if !features.contains(wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS) {
        features.remove(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES);
    }
    features
}

/// A device from the first adapter `choice` allows (in the order of [`adapter_infos`]) that
/// has `request.required_features` and grants a device. `WGPU_BACKEND` chooses the backends
/// searched and `WGPU_ADAPTER_NAME` (a case-insensitive part of the name) narrows the
/// adapters. The error names the backends, the choice and every adapter seen.
pub fn acquire(choice: AdapterChoice, request: &DeviceRequest) -> Result<GpuContext, GpuError> {
    let (instance, backends) = instance();
    let name_filter = std::env::var("WGPU_ADAPTER_NAME").ok().map(|n| n.to_lowercase()).filter(|n| !n.is_empty());
    let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
    adapters.sort_by_key(|a| rank(&a.get_info()));
    let mut seen = Vec::new();
    let mut first_refusal = None;
    for adapter in adapters {
        let info = adapter.get_info();
        let software = is_software(&info);
        let described = format!(
            "{} ({:?}, {} {:?})",
            info.name,
            info.backend,
            if software { "software" } else { "hardware" },
            info.device_type
        );
        let missing = request.required_features - adapter.features();
        let passed_over = if software && choice == AdapterChoice::HardwareOnly {
            Some("software, not allowed".to_owned())
        } else if name_filter.as_ref().is_some_and(|n| !info.name.to_lowercase().contains(n)) {
            Some("name does not match WGPU_ADAPTER_NAME".to_owned())
        } else if !missing.is_empty() {
            Some(format!("lacks {missing:?}"))
        } else {
            None
        };
        if let Some(why) = passed_over {
            seen.push(format!("{described}: {why}"));
            continue;
        }
        let features = grantable(request.required_features | request.optional_features, adapter.features());
        let limits = request.limits.clone().or_worse_values_from(&adapter.limits());
        let descriptor = wgpu::DeviceDescriptor {
            label: Some(request.label),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        };
        match pollster::block_on(adapter.request_device(&descriptor)) {
            Ok((device, queue)) => {
                let info = GpuInfo {
                    name: info.name,
                    backend: info.backend,
                    driver: info.driver,
                    driver_info: info.driver_info,
                    device_type: info.device_type,
                    is_software: software,
                    features: device.features(),
                    limits: device.limits(),
                };
                return Ok(GpuContext { device, queue, info });
            }
            Err(source) => {
                seen.push(format!("{described}: device refused ({source})"));
                first_refusal.get_or_insert(GpuError::RequestDevice { adapter: described, source });
            }
        }
    }
    if let Some(refusal) = first_refusal {
        return Err(refusal);
    }
    Err(GpuError::NoAdapter {
        wanted: choice,
        backends: backends.iter_names().map(|(name, _)| name).collect::<Vec<_>>().join(" | "),
        filter: name_filter.map(|n| format!(", named like {n:?}")).unwrap_or_default(),
        seen,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(name: &str, device_type: wgpu::DeviceType, backend: wgpu::Backend) -> wgpu::AdapterInfo {
        wgpu::AdapterInfo { name: name.into(), ..wgpu::AdapterInfo::new(device_type, backend) }
    }

    #[test]
    fn hardware_adapters_rank_before_software_ones() {
        use wgpu::{Backend, DeviceType};
        let mut adapters = [
            info("llvmpipe (LLVM 15)", DeviceType::Cpu, Backend::Vulkan),
            info("llvmpipe", DeviceType::Other, Backend::Gl),
            info("virtio", DeviceType::VirtualGpu, Backend::Vulkan),
            info("Intel UHD", DeviceType::IntegratedGpu, Backend::Gl),
            info("Intel UHD", DeviceType::IntegratedGpu, Backend::Vulkan),
            info("RTX", DeviceType::DiscreteGpu, Backend::Gl),
            info("unknown", DeviceType::Other, Backend::Vulkan),
        ];
        adapters.sort_by_key(rank);
        let order: Vec<(&str, Backend)> = adapters.iter().map(|a| (a.name.as_str(), a.backend)).collect();
        assert_eq!(
            order,
            [
                ("RTX", Backend::Gl),
                ("Intel UHD", Backend::Vulkan),
                ("Intel UHD", Backend::Gl),
                ("virtio", Backend::Vulkan),
                ("unknown", Backend::Vulkan),
                ("llvmpipe (LLVM 15)", Backend::Vulkan),
                ("llvmpipe", Backend::Gl),
            ]
        );
        // A software renderer reported with another type is still software.
        assert!(is_software(&info("llvmpipe", DeviceType::Other, Backend::Gl)));
        assert!(!is_software(&info("RTX", DeviceType::DiscreteGpu, Backend::Vulkan)));
    }

    #[test]
    fn timestamp_features_are_granted_only_with_their_dependencies() {
        use wgpu::Features as F;
        assert_eq!(grantable(TIMESTAMP_FEATURES, TIMESTAMP_FEATURES), TIMESTAMP_FEATURES);
        assert_eq!(grantable(TIMESTAMP_FEATURES, F::empty()), F::empty());
        assert_eq!(grantable(TIMESTAMP_FEATURES, F::TIMESTAMP_QUERY), F::TIMESTAMP_QUERY);
        // Inside-pass timestamps without inside-encoder ones, or either without pass ones:
        // nothing the device could use.
        assert_eq!(
            grantable(TIMESTAMP_FEATURES, F::TIMESTAMP_QUERY | F::TIMESTAMP_QUERY_INSIDE_PASSES),
            F::TIMESTAMP_QUERY
        );
        assert_eq!(grantable(TIMESTAMP_FEATURES, F::TIMESTAMP_QUERY_INSIDE_ENCODERS), F::empty());
        // Only what was wanted.
        assert_eq!(grantable(F::empty(), TIMESTAMP_FEATURES), F::empty());
    }

    #[test]
    fn no_adapter_error_names_what_was_looked_for_and_seen() {
        let e = GpuError::NoAdapter {
            wanted: AdapterChoice::HardwareOnly,
            backends: "VULKAN".into(),
            filter: String::new(),
            seen: vec!["llvmpipe (Vulkan, software Cpu): software, not allowed".into()],
        };
        assert_eq!(
            e.to_string(),
            "no GPU adapter: looked for a hardware adapter on backends VULKAN; adapters seen: llvmpipe (Vulkan, software Cpu): software, not allowed"
        );
        let e = GpuError::NoAdapter {
            wanted: AdapterChoice::HardwareThenSoftware,
            backends: "GL".into(),
            filter: ", named like \"rtx\"".into(),
            seen: vec![],
        };
        assert!(
            e.to_string().ends_with("then a software one on backends GL, named like \"rtx\"; adapters seen: none"),
            "{e}"
        );
    }
}
