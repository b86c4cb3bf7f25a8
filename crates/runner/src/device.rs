//! The device a kind times its GPU path on, as the runner sees it: the `gpu = "auto" | "off" |
//! "required"` setting, and an opened device — a name for the manifest and a handle only the
//! kind knows the type of. The runner never touches a GPU itself: a kind opens its device
//! ([`crate::Kind::open_device`]) and finds it again in [`crate::Ctx::device`].

use std::any::Any;

/// Whether to use the GPU path.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GpuMode {
    /// Use a GPU when an adapter exists; otherwise print a notice and go on with the CPU.
    #[default]
    Auto,
    Off,
    /// Fail (exit status 2) without an adapter.
    Required,
}

shscale_names::names!(GpuMode { Auto = "auto", Off = "off", Required = "required" });

impl GpuMode {
    /// `"auto"`, `"off"` or `"required"`.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| shscale_names::one_of(s, Self::NAMES))
    }
}

/// An opened device: its description (recorded in the manifest's provenance) and a handle of a
/// type the kind that opened it knows.
pub struct Device {
    description: String,
    handle: Box<dyn Any + Send + Sync>,
}

impl Device {
    pub fn new<T: Any + Send + Sync>(description: impl Into<String>, handle: T) -> Self {
        Self {
            description: description.into(),
            handle: Box::new(handle),
        }
    }

    /// The adapter in words (`name (backend, type)`).
    pub fn description(&self) -> &str {
        &self.description
    }

    /// The handle, when it is a `T`.
    pub fn get<T: Any>(&self) -> Option<&T> {
        self.handle.downcast_ref::<T>()
    }
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Device")
            .field("description", &self.description)
            .finish_non_exhaustive()
    }
}
