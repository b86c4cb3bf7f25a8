//! The experiment core of shscale: every experiment kind behind one seam ([`Kind`]), run by one
//! runner with run ids, resume, shards, merge, Slurm scripts, locking and a manifest — and nothing
//! numerical. It knows configs, records, files and plots (the last two through the ground floor's
//! `shscale_files` and `shscale_present`); what a kind computes, and on which
//! device, is the kind's business ([`Kind::open_device`], [`Ctx::device`]).
//!
//! | module | what it owns |
//! |---|---|
//! | [`kind`] | the seam: [`Kind`], its type-erased [`DynKind`], [`Ctx`], [`Cost`], [`KeyError`] |
//! | [`config`] | config expansion: overrides, `[sweep]` products and zips, places of errors |
//! | [`records`] | rows as CSV cells, run ids, the results table |
//! | [`plan`], [`cost`] | a config resolved into runs (or surveyed for `--dry-run`); its cost and limits |
//! | [`store`] | a results directory's lock, header and validated rows |
//! | [`manifest`] | provenance and `manifest.toml` |
//! | [`run`] | running a plan (resume, shards, groups) |
//! | [`merge`], [`slurm`] | joining shard files; job-array scripts |
//! | [`report`] | the summary, `report.md` and `report.html` |
//! | (`shscale_present`) | plots, figures, images, fonts, Markdown: the ground floor's presentation crate |
//! | [`timing`], [`limits`] | the timing procedure; the work limits |
//! | [`bench`] | the runner's own cost per run (`shscale bench runner`) |
//! | (`shscale_files`) | atomic, durable file output; regular-file input; the results table (the ground floor's) |
//! | [`inputs`], [`fingerprint`] | inputs by content; the numerical code's identity |
//! | [`contention`] | how busy the machine was while a run was timed |
//! | [`check`] | range checks that state the range they test |
//! | [`reference`] | the config reference |
//! | [`device`] | the `gpu` setting and an opened device |

pub mod bench;
pub mod check;
pub mod compare;
pub mod config;
pub mod contention;
pub mod cost;
pub mod device;
pub mod error;
pub mod fingerprint;
pub mod inputs;
pub mod kind;
pub mod limits;
pub mod manifest;
pub mod merge;
pub mod plan;
pub mod records;
pub mod reference;
pub mod report;
pub mod run;
pub mod schema;
pub mod slurm;
pub mod store;
pub mod timing;

pub use device::{Device, GpuMode};
pub use error::Error;
pub use kind::{Cost, Ctx, DynKind, Erased, KeyError, Kind, Resolved, RowCells, Typed};
pub use manifest::Manifest;
pub use merge::{merge, MergeOptions, MergeSummary};
pub use plan::{Plan, StalePolicy};
pub use report::{commit_report, report, report_staged, title_and_claim, Report};
pub use run::{run_plan, run_plan_until, RunEvent, RunSummary};
pub use shscale_files::atomic::{write_atomic, write_atomic_all, write_atomic_bytes, Staging};
pub use slurm::{shell_quote, slurm_script, SlurmOptions};
pub use store::{header, load_rows};
