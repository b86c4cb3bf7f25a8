//! `shscale sh eval|cap|rotate`.

use crate::args::{parse_list, Format, ShCommand};
use crate::output::{print_coeffs, print_json};
use anyhow::{bail, Context};
use serde::Serialize;
use shscale_sh::{cap_coeffs, check_order, euler_zyz, ShBasis, ShRotation};
use std::process::ExitCode;

#[derive(Serialize)]
struct Values<'a> {
    order: usize,
    values: &'a [f64],
}

#[derive(Serialize)]
struct CapValues<'a> {
    order: usize,
    angle_deg: f64,
    values: &'a [f64],
}

pub fn run(cmd: ShCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        ShCommand::Eval { order, dir, format } => {
            check_order(order).context("--order")?;
            let d = parse_list("dir", &dir)?;
            if d.len() != 3 {
                bail!("--dir: expected 3 components X,Y,Z, got {}", d.len());
            }
            let basis = ShBasis::<f64>::new(order)?;
            let mut values = vec![0.0; order * order];
            basis
                .eval_dir([d[0], d[1], d[2]], &mut values)
                .context("--dir")?;
            emit(
                format,
                &Values {
                    order,
                    values: &values,
                },
                &values,
            )
        }
        ShCommand::Cap {
            order,
            angle_deg,
            format,
        } => {
            check_order(order).context("--order")?;
            if !(0.0..=180.0).contains(&angle_deg) {
                bail!("--angle-deg: {angle_deg} is outside [0, 180]");
            }
            let values = cap_coeffs(order, angle_deg.to_radians())?;
            emit(
                format,
                &CapValues {
                    order,
                    angle_deg,
                    values: &values,
                },
                &values,
            )
        }
        ShCommand::Rotate {
            order,
            coeffs,
            euler_zyz_deg,
            format,
        } => {
            check_order(order).context("--order")?;
            let c = parse_list("coeffs", &coeffs)?;
            if c.len() != order * order {
                bail!(
                    "--coeffs: order {order} needs {} coefficients, got {}",
                    order * order,
                    c.len()
                );
            }
            if let Some(i) = c.iter().position(|v| !v.is_finite()) {
                bail!("--coeffs: item {} ({}) is not finite", i + 1, c[i]);
            }
            let e = parse_list("euler-zyz-deg", &euler_zyz_deg)?;
            if e.len() != 3 || e.iter().any(|v| !v.is_finite()) {
                bail!("--euler-zyz-deg: expected 3 finite angles A,B,C in degrees, got {euler_zyz_deg:?}");
            }
            let r = euler_zyz(e[0].to_radians(), e[1].to_radians(), e[2].to_radians());
            let rot = ShRotation::new(order, &r)?;
            let mut values = vec![0.0; order * order];
            rot.apply(&c, &mut values)?;
            emit(
                format,
                &Values {
                    order,
                    values: &values,
                },
                &values,
            )
        }
    }
}

fn emit<T: Serialize>(format: Format, json: &T, values: &[f64]) -> anyhow::Result<ExitCode> {
    match format {
        Format::Json => print_json(json)?,
        f => print_coeffs(values, f),
    }
    Ok(ExitCode::SUCCESS)
}
