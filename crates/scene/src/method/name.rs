//! The methods' names: [`Method`], spelled one way in the config's `method` cell, the CSV
//! column, `render --method` and Python (docs/methods.md). A file of its own so that what a
//! method is called stands below what each method's file reads and sets.

/// A method of computing a receiver's visibility.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// SH-scaling extrapolation from one base-sphere visibility per occluder (the papers').
    Extrapolated,
    /// The fully sampled shadow field (Zhou et al. 2005): shells of samples, interpolated.
    FullField,
    /// Band-limited ray-traced visibility (the converged stratified truth at `4T²` rays per
    /// receiver), shaded through SH like the others.
    RayTraced,
    /// Full-frequency truth: direct quadrature of `∫ L Π V cos⁺` with exact ray-cast visibility.
    FullFrequency,
    /// Sub-volumes (TR §6, SHS §5 future work): every mesh occluder split into parts, each part
    /// extrapolated from its own bounding sphere, multiplied near to far.
    SubVolumes,
    /// Sphere sets (Ren et al. 2006's occluder model): one sphere fitted per part, closed-form
    /// caps; no rays.
    SphereSet,
}

shscale_names::names!(Method {
    Extrapolated = "extrapolated",
    FullField = "full_field",
    RayTraced = "ray_traced",
    FullFrequency = "full_frequency",
    SubVolumes = "sub_volumes",
    SphereSet = "sphere_set",
});

impl Method {
    /// Every method, in the order of the docs.
    pub const ALL: [Method; 6] = [
        Method::Extrapolated,
        Method::FullField,
        Method::RayTraced,
        Method::FullFrequency,
        Method::SubVolumes,
        Method::SphereSet,
    ];
    /// The methods a budget study compares (full-frequency truth is its reference, not a
    /// method under a budget).
    pub(crate) const BUDGETED: [Method; 5] = [
        Method::Extrapolated,
        Method::FullField,
        Method::RayTraced,
        Method::SubVolumes,
        Method::SphereSet,
    ];
    /// The command line's earlier spellings, still accepted by [`Method::parse_cli`].
    const CLI_ALIASES: [(&'static str, Method); 3] = [
        ("full-field", Method::FullField),
        ("raytraced", Method::RayTraced),
        ("raytraced-full", Method::FullFrequency),
    ];

    /// The method named `s` among `among`, or a message listing them.
    pub(crate) fn parse_among(s: &str, among: &[Method]) -> Result<Self, String> {
        among
            .iter()
            .copied()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                let names: Vec<String> = among.iter().map(|m| format!("{:?}", m.name())).collect();
                format!("{s:?} is not one of {}", names.join(", "))
            })
    }

    /// Any method by its name.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::parse_among(s, &Self::ALL)
    }

    /// A method as the command line takes it: its name, or an earlier spelling
    /// (`full-field`, `raytraced`, `raytraced-full`).
    pub fn parse_cli(s: &str) -> Result<Self, String> {
        (Self::CLI_ALIASES.iter())
            .find(|(a, _)| *a == s)
            .map(|(_, m)| *m)
            .map_or_else(|| Self::parse(s), Ok)
    }

    /// The references: ray-traced truths, band-limited and full-frequency.
    pub fn is_truth(self) -> bool {
        matches!(self, Method::RayTraced | Method::FullFrequency)
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
