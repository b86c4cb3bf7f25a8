//! `shscale matrix`: one dense scaling matrix, or a k-table with its interpolation error.

use crate::args::{parse_list, Format, InterpArg, MatrixArgs, SpacingArg, TauArg};
use crate::flags;
use crate::output::{print_json, print_matrix};
use anyhow::{bail, Context};
use serde::Serialize;
use shscale_scaling::{
    structural_nonzeros, Eta, Interp, KTable, ScalingMatrix, Spacing, TauFamily,
};
use shscale_scene::vocab::MAX_K_COUNT;
use std::process::ExitCode;
use std::time::Instant;

/// Largest order this command accepts (the dense output has N⁴ entries).
pub const MATRIX_MAX_ORDER: usize = 32;

/// Entries of magnitude above this count as non-zero in the output.
pub const NONZERO_THRESHOLD: f64 = 1e-12;

#[derive(Serialize)]
struct MatrixOut<'a> {
    order: usize,
    tau: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    alpha_deg: Option<f64>,
    k: f64,
    energy: bool,
    structural_nonzeros: usize,
    nonzeros: usize,
    matrix: &'a [Vec<f64>],
}

#[derive(Serialize)]
struct TableOut {
    order: usize,
    tau: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    alpha_deg: Option<f64>,
    energy: bool,
    k_count: usize,
    k_min: f64,
    k_max: f64,
    spacing: String,
    interp: String,
    size_bytes: usize,
    build_seconds: f64,
    max_interp_error: f64,
    max_interp_error_k: f64,
}

pub fn run(a: MatrixArgs) -> anyhow::Result<ExitCode> {
    flags::int("--order", a.order, 1, MATRIX_MAX_ORDER)?;
    let family = family_of(&a)?;
    let alpha_deg = if a.tau == TauArg::Cone {
        a.alpha_deg
    } else {
        None
    };
    let eta = if a.energy { Eta::Energy } else { Eta::Plain };
    match (a.k, a.table) {
        (Some(_), Some(_)) => bail!("--k and --table are exclusive: give one"),
        (None, None) => bail!("give --k K for one matrix, or --table K_COUNT --k-range KMIN,KMAX"),
        (Some(k), None) => one_matrix(&a, family, alpha_deg, eta, k)?,
        (None, Some(count)) => table(&a, family, alpha_deg, eta, count)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// The τ family of `--tau` (with `--alpha-deg` for the cone, and only for it).
fn family_of(a: &MatrixArgs) -> anyhow::Result<TauFamily> {
    Ok(match a.tau {
        TauArg::Cone => {
            let alpha = a
                .alpha_deg
                .context("--alpha-deg is required for --tau cone")?;
            shscale_scene::vocab::AlphaDeg::new(alpha)
                .map_err(|m| anyhow::anyhow!("--alpha-deg: {m}"))?;
            TauFamily::Cone {
                alpha: alpha.to_radians(),
            }
        }
        TauArg::Midrange => {
            if a.alpha_deg.is_some() {
                bail!("--alpha-deg applies to --tau cone only");
            }
            TauFamily::MidRange
        }
    })
}

/// `--k K`: one matrix, printed whole.
fn one_matrix(
    a: &MatrixArgs,
    family: TauFamily,
    alpha_deg: Option<f64>,
    eta: Eta,
    k: f64,
) -> anyhow::Result<()> {
    let tau = family.at(k).context("--k")?;
    let m = ScalingMatrix::compute(tau.as_ref(), eta, a.order)?;
    let dense = m.to_dense();
    match a.format {
        Format::Json => print_json(&MatrixOut {
            order: a.order,
            tau: family.name(),
            alpha_deg,
            k,
            energy: a.energy,
            structural_nonzeros: structural_nonzeros(a.order),
            nonzeros: m.nonzeros(NONZERO_THRESHOLD),
            matrix: &dense,
        })?,
        Format::Csv => print_matrix(&dense, Format::Csv),
        Format::Pretty => {
            println!(
                "{} scaling matrix, order {}, k = {k}{}, η = {}: {} structural non-zeros, {} non-zero (|M| > 1e-12)",
                family.name(),
                a.order,
                alpha_deg.map(|v| format!(", α = {v}°")).unwrap_or_default(),
                if a.energy { "energy" } else { "plain" },
                structural_nonzeros(a.order),
                m.nonzeros(NONZERO_THRESHOLD)
            );
            print_matrix(&dense, Format::Pretty);
        }
    }
    Ok(())
}

/// `--table K_COUNT --k-range KMIN,KMAX`: build a k-table, report its size, build time and
/// worst interpolation error.
fn table(
    a: &MatrixArgs,
    family: TauFamily,
    alpha_deg: Option<f64>,
    eta: Eta,
    count: usize,
) -> anyhow::Result<()> {
    // The same bound as `k_count` of the experiment kinds: at N = 32 a table of 10⁴
    // matrices (≈ 0.06 s each here, ×4 with the error check) takes ≈ 40 min and 1.7 GB.
    flags::int("--table", count, 2, MAX_K_COUNT)?;
    let range = a
        .k_range
        .as_deref()
        .context("--table needs --k-range KMIN,KMAX")?;
    let r = parse_list("k-range", range)?;
    if r.len() != 2 {
        bail!("--k-range: expected KMIN,KMAX, got {} values", r.len());
    }
    let spacing = match a.spacing {
        SpacingArg::Exp => Spacing::Exp,
        SpacingArg::Uniform => Spacing::Uniform,
        SpacingArg::Chebyshev => Spacing::Chebyshev,
    };
    let interp = match a.interp {
        InterpArg::Linear => Interp::Linear,
        InterpArg::Cubic => Interp::Cubic,
    };
    let t0 = Instant::now();
    let table = KTable::build(family, eta, a.order, count, r[0], r[1], spacing, interp)
        .context("--table/--k-range")?;
    let build_seconds = t0.elapsed().as_secs_f64();
    let (err, at) = table.max_interp_error(3)?;
    let out = TableOut {
        order: a.order,
        tau: family.name(),
        alpha_deg,
        energy: a.energy,
        k_count: count,
        k_min: r[0],
        k_max: r[1],
        spacing: format!("{:?}", a.spacing).to_lowercase(),
        interp: format!("{:?}", a.interp).to_lowercase(),
        size_bytes: table.size_bytes(),
        build_seconds,
        max_interp_error: err,
        max_interp_error_k: at,
    };
    print_table(a.format, &out)
}

/// A k-table's report in `format`.
fn print_table(format: Format, out: &TableOut) -> anyhow::Result<()> {
    match format {
        Format::Json => print_json(&out)?,
        Format::Csv => {
            println!("order,tau,alpha_deg,energy,k_count,k_min,k_max,spacing,interp,size_bytes,build_seconds,max_interp_error,max_interp_error_k");
            println!(
                "{},{},{},{},{},{},{},{},{},{},{},{:e},{}",
                out.order,
                out.tau,
                out.alpha_deg.map(|v| v.to_string()).unwrap_or_default(),
                out.energy,
                out.k_count,
                out.k_min,
                out.k_max,
                out.spacing,
                out.interp,
                out.size_bytes,
                out.build_seconds,
                out.max_interp_error,
                out.max_interp_error_k
            );
        }
        Format::Pretty => {
            println!(
                "k-table: {} matrices of order {} over k ∈ [{}, {}] ({} spacing, {} interpolation)",
                out.k_count, out.order, out.k_min, out.k_max, out.spacing, out.interp
            );
            println!("  size                 {} bytes", out.size_bytes);
            println!("  build time           {:.3} ms", out.build_seconds * 1e3);
            println!(
                "  worst interp. error  {:.3e} (max |ΔM_ij|) at k = {:.6}",
                out.max_interp_error, out.max_interp_error_k
            );
        }
    }
    Ok(())
}
