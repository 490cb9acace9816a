//! `vadscope labels`: opens a scenario's labels (recovering from a crash or a damaged file
//! and saying so), imports and exports them, and prints a summary.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::Args;
use vadscope::annotate::{
    Edit, Editor, Interval, IntervalId, LabelFormat, LabelSet, Origin, export_labels, import_labels,
};
use vadscope::sequence::Scenario;

/// Options of `vadscope labels`.
#[derive(Debug, Args)]
pub struct LabelsArgs {
    /// The scenario folder.
    scenario: PathBuf,
    /// Replace the labels the file's format carries with the file's content (one undoable
    /// edit).
    #[arg(long, value_name = "FILE", requires = "format")]
    import: Option<PathBuf>,
    /// Write the labels to FILE (a folder for `yolo`).
    #[arg(long, value_name = "FILE", requires = "format")]
    export: Option<PathBuf>,
    /// The format of `--import` / `--export`.
    #[arg(long, value_name = "F", value_parser = parse_format)]
    format: Option<LabelFormat>,
    /// Print the intervals, tags and notes.
    #[arg(long)]
    show: bool,
    /// Applies N interval edits one by one, printing `ack <id> <start> <end>` after each
    /// is on disk (for the crash test).
    #[arg(long, value_name = "N", hide = true)]
    stress_edits: Option<usize>,
}

/// Parses a label format name (shared with `vadscope export --labels`).
pub(super) fn parse_format(name: &str) -> Result<LabelFormat, String> {
    LabelFormat::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = LabelFormat::ALL.iter().map(|f| f.name()).collect();
        format!("unknown format {name:?}; one of {}", names.join(", "))
    })
}

/// Runs `vadscope labels`.
pub fn run(args: LabelsArgs) -> anyhow::Result<ExitCode> {
    let scenario = Scenario::open(&args.scenario)?;
    let mut editor = open_editor(&scenario)?;
    if let Some(n) = args.stress_edits {
        return stress(&mut editor, n);
    }
    if args.import.is_none() && args.export.is_none() && !args.show {
        bail!("nothing to do: give --import, --export or --show");
    }
    if let (Some(path), Some(format)) = (&args.import, args.format) {
        let import = import_labels(&scenario, editor.labels(), format, path)?;
        editor
            .apply(import.edit)
            .with_context(|| format!("applying {}", path.display()))?;
        editor.compact()?;
        println!(
            "imported {} rows from {} ({format}){}",
            import.records,
            path.display(),
            if import.unmatched > 0 {
                format!(
                    ", {} for frames not in the scenario skipped",
                    import.unmatched
                )
            } else {
                String::new()
            }
        );
    }
    if let (Some(path), Some(format)) = (&args.export, args.format) {
        let summary = export_labels(&scenario, editor.labels(), format, path)?;
        println!(
            "exported {} rows in {} file(s) to {} ({format})",
            summary.records,
            summary.files,
            path.display()
        );
    }
    if args.show {
        show(&scenario, editor.labels(), &editor);
    }
    Ok(ExitCode::SUCCESS)
}

/// Opens the labels of `scenario`, warning about what recovery found (damaged files kept
/// aside, journal records that did not apply).
pub(super) fn open_editor(scenario: &Scenario) -> anyhow::Result<Editor> {
    let editor = Editor::open(scenario)
        .with_context(|| format!("opening the labels of {}", scenario.root().display()))?;
    for problem in editor.load_problems() {
        eprintln!("warning: {problem}");
    }
    for copy in editor.set_aside() {
        eprintln!("warning: the damaged file was kept as {}", copy.display());
    }
    Ok(editor)
}

fn show(scenario: &Scenario, labels: &LabelSet, editor: &Editor) {
    let id = |index: usize| labels.frame_id(index).map_or(0, |f| f.0);
    println!("{}: {} frames", scenario.name(), labels.frame_count());
    if let Some(dir) = editor.dir() {
        println!("labels in {}", dir.display());
    }
    let keyframes: usize = labels.tracks().map(|t| t.keyframes.len()).sum();
    println!(
        "{} intervals, {} tracks ({keyframes} keyframes), {} tags, {} notes",
        labels.intervals().len(),
        labels.tracks().len(),
        labels.tags().len(),
        labels.notes().len()
    );
    for i in labels.intervals() {
        println!(
            "interval {}: #{}-#{} (ids {}-{}) {} [{:?}] {}",
            i.id.0,
            i.start,
            i.end,
            id(i.start),
            id(i.end),
            i.class,
            i.origin,
            i.note
        );
    }
    for t in labels.tags() {
        println!(
            "tag {}: #{}-#{} (ids {}-{}) {} {}",
            t.id.0,
            t.start,
            t.end,
            id(t.start),
            id(t.end),
            t.tag,
            t.note
        );
    }
    for (frame, text) in labels.notes() {
        println!("note #{frame} (id {}): {text}", id(frame));
    }
}

fn stress(editor: &mut Editor, n: usize) -> anyhow::Result<ExitCode> {
    let frames = editor.labels().frame_count();
    if frames == 0 {
        bail!("the scenario has no frames");
    }
    let mut out = std::io::stdout().lock();
    for k in 0..n {
        let id: IntervalId = editor.labels().fresh_interval_id();
        let start = k % frames;
        let end = (start + k % 5).min(frames - 1);
        editor.apply(Edit::AddInterval(Interval {
            id,
            start,
            end,
            class: "stress".into(),
            note: format!("stress {k}"),
            origin: Origin::Analyst,
        }))?;
        writeln!(out, "ack {} {start} {end}", id.0)?;
        out.flush()?;
    }
    Ok(ExitCode::SUCCESS)
}
