//! Which CPU a benchmark ran on: vendor, family and model, the microarchitecture they name, and
//! the SIMD level the kernels dispatched to — so that every benchmark row says which machine
//! its ratio belongs to (docs/BENCHMARKS.md keeps one table per CPU kind).
//!
//! x86-64: CPUID leaves 0 (vendor), 1 (family, model, stepping with the extended fields
//! folded in as the vendors' manuals define them) and 0x8000_0002–4 (brand string). aarch64 on
//! Linux: `/proc/cpuinfo`'s `CPU implementer` and `CPU part` (the MIDR fields). The
//! microarchitecture comes from a table of the kinds this project is likely to land on; a kind
//! outside it is reported as `unknown` with its numbers, never guessed.

/// One CPU's identity, as benchmark rows report it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cpu {
    /// `AuthenticAMD`, `GenuineIntel`, `ARM`, `Apple`, … or `unknown`.
    pub vendor: String,
    /// x86: the display family (base + extended); aarch64: the MIDR implementer code.
    pub family: u32,
    /// x86: the display model (extended model folded in); aarch64: the MIDR part number.
    pub model: u32,
    /// The microarchitecture family and model name (`Zen 4`, `Ice Lake-SP`, `Neoverse N1`),
    /// or `unknown`.
    pub microarchitecture: String,
    /// The brand string the CPU reports (a VM often shows only `AMD EPYC`); may be empty.
    pub brand: String,
    /// The instruction set the batched kernels dispatched to in this process
    /// ([`crate::simd::level`]).
    pub simd: String,
    /// The best level this CPU has, whatever `SHSCALE_SIMD` says.
    pub simd_detected: String,
}

impl Cpu {
    /// One line for text output: `AMD EPYC (AuthenticAMD family 26 model 2: Zen 5; has avx512)`
    /// — the CPU and the best level it has (a row says which level its kernel ran).
    pub fn summary(&self) -> String {
        let brand = if self.brand.is_empty() {
            self.vendor.as_str()
        } else {
            self.brand.as_str()
        };
        format!(
            "{brand} ({} family {} model {}: {}; has {})",
            self.vendor, self.family, self.model, self.microarchitecture, self.simd_detected
        )
    }
}

/// This machine's CPU (read once per process).
pub fn cpu() -> Cpu {
    static CPU: std::sync::OnceLock<Cpu> = std::sync::OnceLock::new();
    CPU.get_or_init(read).clone()
}

fn read() -> Cpu {
    let (vendor, family, model, brand) = identity();
    Cpu {
        microarchitecture: microarchitecture(&vendor, family, model).to_string(),
        vendor,
        family,
        model,
        brand,
        simd: crate::simd::level().name().into(),
        simd_detected: crate::simd::detected().name().into(),
    }
}

#[cfg(target_arch = "x86_64")]
fn identity() -> (String, u32, u32, String) {
    use std::arch::x86_64::__cpuid;
    // CPUID exists on every x86-64 CPU; leaves above the reported maxima are not queried.
    let l0 = __cpuid(0);
    let mut v = Vec::with_capacity(12);
    for r in [l0.ebx, l0.edx, l0.ecx] {
        v.extend_from_slice(&r.to_le_bytes());
    }
    let vendor = String::from_utf8_lossy(&v).trim().to_string();
    let (family, model) = if l0.eax >= 1 {
        display_family_model(__cpuid(1).eax)
    } else {
        (0, 0)
    };
    let ext = __cpuid(0x8000_0000).eax;
    let mut brand = Vec::with_capacity(48);
    if ext >= 0x8000_0004 {
        for leaf in 0x8000_0002u32..=0x8000_0004 {
            let r = __cpuid(leaf);
            for x in [r.eax, r.ebx, r.ecx, r.edx] {
                brand.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    let brand = String::from_utf8_lossy(&brand)
        .trim_matches(char::from(0))
        .trim()
        .to_string();
    (vendor, family, model, brand)
}

#[cfg(not(target_arch = "x86_64"))]
fn identity() -> (String, u32, u32, String) {
    match std::fs::read_to_string("/proc/cpuinfo") {
        Ok(text) => midr_identity(&text),
        Err(_) => ("unknown".into(), 0, 0, String::new()),
    }
}

/// x86 CPUID leaf 1's EAX as the display family and model: the extended family is added when
/// the base family is 15, and the extended model is prepended when the base family is 6 or 15
/// (Intel SDM vol. 2A, CPUID; AMD APM vol. 3, CPUID Fn0000_0001_EAX).
pub fn display_family_model(eax: u32) -> (u32, u32) {
    let base_family = (eax >> 8) & 0xF;
    let base_model = (eax >> 4) & 0xF;
    let ext_model = (eax >> 16) & 0xF;
    let ext_family = (eax >> 20) & 0xFF;
    let family = if base_family == 15 {
        base_family + ext_family
    } else {
        base_family
    };
    let model = if base_family == 6 || base_family == 15 {
        (ext_model << 4) | base_model
    } else {
        base_model
    };
    (family, model)
}

/// aarch64 Linux `/proc/cpuinfo`: the first `CPU implementer` and `CPU part` (hexadecimal), the
/// implementer named (`ARM`, `Apple`, …); `unknown` and zeros where they are missing.
pub fn midr_identity(cpuinfo: &str) -> (String, u32, u32, String) {
    let field = |name: &str| {
        cpuinfo.lines().find_map(|l| {
            let (k, v) = l.split_once(':')?;
            (k.trim() == name).then(|| {
                let v = v.trim();
                u32::from_str_radix(v.trim_start_matches("0x"), 16).ok()
            })?
        })
    };
    let (Some(imp), Some(part)) = (field("CPU implementer"), field("CPU part")) else {
        return ("unknown".into(), 0, 0, String::new());
    };
    let vendor = match imp {
        0x41 => "ARM",
        0x61 => "Apple",
        0xC0 => "Ampere",
        0x48 => "HiSilicon",
        0x51 => "Qualcomm",
        0x4E => "NVIDIA",
        _ => "unknown",
    };
    (vendor.into(), imp, part, String::new())
}

/// The microarchitecture a vendor's family and model name, for the kinds in the table below;
/// `unknown` otherwise. AMD: families 23 (0x17, Zen to Zen 2), 25 (0x19, Zen 3 and 4), 26
/// (0x1A, Zen 5) by model range; Intel family 6 by model number (server and common client
/// parts since Haswell); Arm: the Neoverse and Cortex-X/A7x cores by part number; Apple: M1 to
/// M4 by part number.
pub fn microarchitecture(vendor: &str, family: u32, model: u32) -> &'static str {
    match vendor {
        "AuthenticAMD" | "HygonGenuine" => amd(family, model),
        "GenuineIntel" if family == 6 => intel6(model),
        "ARM" => match model {
            0xD0B => "Cortex-A76",
            0xD0C => "Neoverse N1",
            0xD0D => "Cortex-A77",
            0xD40 => "Neoverse V1",
            0xD41 => "Cortex-A78",
            0xD44 => "Cortex-X1",
            0xD49 => "Neoverse N2",
            0xD4F => "Neoverse V2",
            0xD8E => "Neoverse N3",
            0xD84 => "Neoverse V3",
            _ => "unknown",
        },
        "Apple" => match model {
            0x22..=0x25 | 0x28 | 0x29 => "Apple M1",
            0x32..=0x39 => "Apple M2",
            0x48 | 0x49 => "Apple M3",
            0x52..=0x55 => "Apple M4",
            _ => "unknown",
        },
        _ => "unknown",
    }
}

fn amd(family: u32, model: u32) -> &'static str {
    match (family, model) {
        (0x17, 0x08 | 0x18) => "Zen+",
        (0x17, 0x00..=0x2F) => "Zen",
        (0x17, 0x30..=0xFF) => "Zen 2",
        (0x19, 0x00..=0x0F | 0x20..=0x5F) => "Zen 3",
        (0x19, 0x10..=0x1F | 0x60..=0x7F | 0xA0..=0xAF) => "Zen 4",
        (0x1A, _) => "Zen 5",
        _ => "unknown",
    }
}

fn intel6(model: u32) -> &'static str {
    match model {
        0x3C | 0x3F | 0x45 | 0x46 => "Haswell",
        0x3D | 0x47 | 0x4F | 0x56 => "Broadwell",
        0x4E | 0x5E => "Skylake",
        0x55 => "Skylake-SP / Cascade Lake",
        0x8E | 0x9E | 0xA5 | 0xA6 => "Kaby / Coffee / Comet Lake",
        0x6A | 0x6C => "Ice Lake-SP",
        0x7D | 0x7E => "Ice Lake",
        0x8C | 0x8D => "Tiger Lake",
        0x8F => "Sapphire Rapids",
        0xCF => "Emerald Rapids",
        0xAD | 0xAE => "Granite Rapids",
        0x97 | 0x9A => "Alder Lake",
        0xB7 | 0xBA | 0xBF => "Raptor Lake",
        0xAA | 0xAC => "Meteor Lake",
        0xBD => "Lunar Lake",
        0xC5 | 0xC6 => "Arrow Lake",
        _ => "unknown",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CPUID leaf-1 signatures of real parts (AMD's and Intel's published family/model/stepping
    /// values) decoded to their display family and model, and named.
    #[test]
    fn signatures_decode_to_their_family_and_model() {
        // (EAX, display family, display model, name)
        let cases = [
            (0x0080_0F12, 23, 0x01, "Zen"), // EPYC 7001 "Naples", family 17h model 01h
            (0x0080_0F82, 23, 0x08, "Zen+"), // Ryzen 2000 "Pinnacle Ridge"
            (0x0083_0F10, 23, 0x31, "Zen 2"), // EPYC 7002 "Rome"
            (0x00A0_0F11, 25, 0x01, "Zen 3"), // EPYC 7003 "Milan"
            (0x00A1_0F11, 25, 0x11, "Zen 4"), // EPYC 9004 "Genoa"
            (0x00B0_0F21, 26, 0x02, "Zen 5"), // EPYC 9005 "Turin"
            (0x0005_0654, 6, 0x55, "Skylake-SP / Cascade Lake"),
            (0x0006_06A6, 6, 0x6A, "Ice Lake-SP"),
            (0x0008_06F8, 6, 0x8F, "Sapphire Rapids"),
            (0x0009_0672, 6, 0x97, "Alder Lake"),
            (0x0000_0F29, 15, 0x02, "unknown"), // a Pentium 4: family 15, no extended parts
        ];
        for (eax, fam, model, name) in cases {
            let (f, m) = display_family_model(eax);
            assert_eq!((f, m), (fam, model), "EAX {eax:#010x}");
            let vendor = if fam == 6 || fam == 15 {
                "GenuineIntel"
            } else {
                "AuthenticAMD"
            };
            assert_eq!(microarchitecture(vendor, f, m), name, "EAX {eax:#010x}");
        }
        // The extended model is ignored for base families other than 6 and 15 (family 5, a
        // Pentium MMX, with nonsense in the extended bits).
        assert_eq!(display_family_model(0x000F_0543), (5, 4));
        assert_eq!(microarchitecture("CyrixInstead", 6, 0x55), "unknown");
        assert_eq!(microarchitecture("AuthenticAMD", 0x18, 0), "unknown");
    }

    #[test]
    fn midr_fields_are_read_from_cpuinfo() {
        let graviton2 = "processor\t: 0\nBogoMIPS\t: 243.75\nCPU implementer\t: 0x41\n\
                         CPU architecture: 8\nCPU variant\t: 0x3\nCPU part\t: 0xd0c\n";
        let (v, imp, part, _) = midr_identity(graviton2);
        assert_eq!((v.as_str(), imp, part), ("ARM", 0x41, 0xD0C));
        assert_eq!(microarchitecture(&v, imp, part), "Neoverse N1");
        // Missing fields: unknown, not a guess.
        let (v, imp, part, _) = midr_identity("processor\t: 0\nCPU part\t: 0xd0c\n");
        assert_eq!((v.as_str(), imp, part), ("unknown", 0, 0));
        assert_eq!(microarchitecture("Apple", 0x61, 0x999), "unknown");
    }

    #[test]
    fn this_cpu_is_described() {
        let c = cpu();
        assert!(!c.vendor.is_empty() && !c.simd.is_empty());
        assert_eq!(c.simd, crate::simd::level().name());
        let s = c.summary();
        assert!(
            s.contains(&c.microarchitecture) && s.contains(&c.simd_detected),
            "{s}"
        );
        println!("this CPU: {s}");
    }
}
