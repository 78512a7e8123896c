//! `mesopush import zhou-mason`: the Zhou & Mason 2017 push logs (`../shared/real-pushes/`)
//! as version-2 trial logs, one directory per run, plus `runs.csv` indexing them. The
//! conventions the data's README leaves open were found from the data; `docs/
//! import-zhou-mason.md` gives each with its evidence.

pub mod convert;
pub mod nominal;
pub mod report;
pub mod run_file;
pub mod setup;
pub mod trial_meta;
pub mod walk;

pub use report::{ImportOptions, ImportReport, RunSummary};

use crate::Error;
use crate::writer::TrialWriter;
use convert::convert;
use run_file::read_run;
use setup::SetUp;
use std::path::Path;
use trial_meta::{RunId, trial_meta};

/// The name of the index written beside the trials.
pub const INDEX: &str = "runs.csv";

/// Who the run in `file` is, from its start folder and file name.
fn run_id(file: &Path) -> Result<RunId, Error> {
    fn name(p: Option<&Path>) -> Option<&str> {
        p?.file_name()?.to_str()
    }
    let (Some(file_name), Some(folder)) = (name(Some(file)), name(file.parent())) else {
        return Err(Error::invalid(
            "zhou-mason run file",
            format!("{}: no start folder", file.display()),
        ));
    };
    let (set_up, start) = SetUp::parse_start_folder(folder)?;
    let stamp = file_name.trim_start_matches("log").trim_end_matches(".txt");
    Ok(RunId {
        set_up,
        trial_id: format!("{}__{start}__{stamp}", set_up.name()),
        file: format!("{}/{folder}/{file_name}", set_up.name()),
        start,
    })
}

/// Imports one run file into `out/<trial id>/`.
pub fn import_run(file: &Path, out: &Path, options: &ImportOptions) -> Result<RunSummary, Error> {
    let id = run_id(file)?;
    let rows = read_run(file)?;
    let conv = convert(&rows, id.set_up.com_mm(), options.vision_latency_s)?;
    let meta = trial_meta(&id, &conv.counts, options.vision_latency_s)?;
    let mut w = TrialWriter::create(&out.join(&id.trial_id), meta)?;
    for r in &conv.probe {
        w.probe(r)?;
    }
    for p in &conv.pose {
        w.pose(p)?;
    }
    for e in &conv.events {
        w.event(e)?;
    }
    w.finish(crate::Outcome { state: crate::TrialState::Done, reason: None, inserted: None })?;
    Ok(RunSummary {
        trial_dir: id.trial_id,
        set_up: id.set_up.name().to_string(),
        start: id.start,
        file: id.file,
        counts: conv.counts,
    })
}

/// Imports every run under `dir` (data root, set-up folder, start folder or one run file)
/// into `out`, and writes `out/runs.csv`.
pub fn import(dir: &Path, out: &Path, options: &ImportOptions) -> Result<ImportReport, Error> {
    options.validate()?;
    let files = walk::run_files(dir)?;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let runs = files.iter().map(|f| import_run(f, out, options)).collect::<Result<Vec<_>, _>>()?;
    let report = ImportReport::new(runs, options);
    report.write_index(&out.join(INDEX))?;
    write_nominal_models(&report, out)?;
    Ok(report)
}

/// Writes `out/nominal-<set-up>.toml` ([`nominal::nominal_model`]) for every set-up imported.
fn write_nominal_models(report: &ImportReport, out: &Path) -> Result<(), Error> {
    for set_up in SetUp::ALL {
        if report.runs.iter().any(|r| r.set_up == set_up.name()) {
            let file = out.join(format!("nominal-{}.toml", set_up.name()));
            nominal::nominal_model(set_up)?.save(&file)?;
        }
    }
    Ok(())
}
