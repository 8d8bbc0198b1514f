//! What a sweep runs: the configurations of `wisptree sweep`, from the cartesian product of its
//! lists (`--model`, `--set NAME=…` for any tunable of the chosen models' tables, and its
//! aliases `--split`, `--merge`) or from a RON file of named variants, with their labels and the
//! recording id all parts of one sweep share.
//!
//! Every mistake here is the user's: a [`BadInput`] (exit 2) naming the flag and the item, or
//! the file, line, column and field, like the style loader.

use std::path::{Path, PathBuf};

use crate::error::BadInput;
use crate::solver::tunable::{self, Tuning};
use crate::solver::SolverKind;

/// One configuration of a sweep: a solver and the tunables it overrides.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepConfig {
    /// `/runs/<label>`: only `[A-Za-z0-9_.-]`.
    pub label: String,
    /// The solver.
    pub model: SolverKind,
    /// `sim.split_threshold`, if the sweep sets it (else the style's).
    pub split: Option<f64>,
    /// `sim.merge_velocity`, if the sweep sets it (else the style's).
    pub merge: Option<f64>,
    /// The other tunables it sets (`--set NAME=…`), by their table names, in the order given.
    pub sets: Vec<(&'static str, f64)>,
}

impl SweepConfig {
    /// The style's sections with this configuration's overrides; a value is set through the
    /// model's own table entry of that name (else the first table that has it: a model that
    /// does not read it ignores it, as single-level ignores the split threshold).
    pub fn tuning(&self, style: &Tuning) -> Tuning {
        let mut t = style.clone();
        if let Some(v) = self.split {
            t.sim.split_threshold = v;
        }
        if let Some(v) = self.merge {
            t.sim.merge_velocity = v;
        }
        for &(name, v) in &self.sets {
            if let Some(e) = entry(self.model, name) {
                (e.set)(&mut t, v);
            }
        }
        t
    }

    /// Every tunable the configuration sets, by name.
    pub fn swept(&self) -> Vec<&'static str> {
        let mut out = Vec::new();
        if self.split.is_some() {
            out.push("split_threshold");
        }
        if self.merge.is_some() {
            out.push("merge_velocity");
        }
        out.extend(self.sets.iter().map(|(n, _)| *n));
        out
    }
}

/// The entry `name` of `model`'s table, else of any table.
fn entry(model: SolverKind, name: &str) -> Option<&'static tunable::Tunable> {
    tunable::find(model.tunables(), name).or_else(|| {
        SolverKind::ALL
            .iter()
            .find_map(|k| tunable::find(k.tunables(), name))
    })
}

/// The lists of a sweep as typed: comma-separated, or none.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SweepLists {
    /// `--model awt,single-level`.
    pub model: Option<String>,
    /// `--split 0.1,0.2`.
    pub split: Option<String>,
    /// `--merge 0.05,0.1`.
    pub merge: Option<String>,
    /// `--set NAME=v1,v2,…`, each as typed (repeatable).
    pub set: Vec<String>,
}

/// Whether `label` may name a run: non-empty, only `[A-Za-z0-9_.-]` (an entity path part).
pub fn label_ok(label: &str) -> bool {
    !label.is_empty()
        && label
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'.' | b'-'))
}

/// A threshold's value, checked as the style loader checks `sim.split_threshold` and
/// `sim.merge_velocity`: finite, zero or positive.
fn threshold(v: f64) -> Result<f64, String> {
    if v.is_finite() && v >= 0.0 {
        // `-0` is zero: the label says `0`, not `-0`.
        Ok(v + 0.0)
    } else {
        Err(format!("must be zero or positive, got {v:?}"))
    }
}

/// The label of a configuration: the solver, then each swept value as `split0.2`, `merge0.1`.
/// Values print shortest-roundtrip (Rust's `{}` for `f64`), so a label is deterministic and
/// reads the value back exactly; `1e-3` becomes `0.001`.
pub fn label_of(model: SolverKind, split: Option<f64>, merge: Option<f64>) -> String {
    label_with(model, split, merge, &[])
}

/// [`label_of`], then each other swept tunable as `_<name><value>`.
pub fn label_with(
    model: SolverKind,
    split: Option<f64>,
    merge: Option<f64>,
    sets: &[(&str, f64)],
) -> String {
    let mut s = model.name().to_owned();
    if let Some(v) = split {
        s.push_str(&format!("_split{v}"));
    }
    if let Some(v) = merge {
        s.push_str(&format!("_merge{v}"));
    }
    for (name, v) in sets {
        s.push_str(&format!("_{name}{v}"));
    }
    s
}

/// One `--set NAME=v1,v2,…`: the tunable's name (checked against the chosen models' tables:
/// at least one must have it) and its values (each checked against that entry's range).
fn set_axis(text: &str, models: &[SolverKind]) -> Result<(&'static str, Vec<f64>), BadInput> {
    let (name, _) = text.split_once('=').ok_or_else(|| {
        BadInput(format!(
            "--set `{text}`: expected NAME=v1,v2,… (for example --set split_threshold=0.1,0.2)"
        ))
    })?;
    let name = name.trim();
    let Some(&kind) = models
        .iter()
        .find(|k| tunable::find(k.tunables(), name).is_some())
    else {
        let tables: Vec<String> = models
            .iter()
            .map(|k| format!("{k}: {}", tunable::names(k.tunables())))
            .collect();
        return Err(BadInput(format!(
            "--set: `{name}` is not a tunable of the swept model{} ({})",
            if models.len() > 1 { "s" } else { "" },
            tables.join("; ")
        )));
    };
    let (e, values) =
        tunable::parse_assignment(kind.tunables(), text, kind.name(), &Tuning::default())
            .map_err(|e| BadInput(format!("--set: {e}")))?;
    for (k, v) in values.iter().enumerate() {
        if values[..k].contains(v) {
            return Err(BadInput(format!(
                "--set: {name} value `{v}` is listed twice (every configuration must differ)"
            )));
        }
    }
    Ok((e.name, values))
}

/// Splits one list flag into its items, each parsed by `parse`; empty items and duplicates
/// are errors naming the flag and the item.
fn list<T: PartialEq>(
    flag: &str,
    text: &str,
    parse: impl Fn(&str) -> Result<T, String>,
) -> Result<Vec<T>, BadInput> {
    let mut out = Vec::new();
    for (k, item) in text.split(',').enumerate() {
        let item = item.trim();
        if item.is_empty() {
            return Err(BadInput(format!(
                "{flag} {text}: item {} is empty (expected a comma-separated list, e.g. {flag} {})",
                k + 1,
                if flag == "--model" {
                    "awt,single-level"
                } else {
                    "0.1,0.2"
                }
            )));
        }
        let v = parse(item).map_err(|why| BadInput(format!("{flag}: `{item}`: {why}")))?;
        if out.contains(&v) {
            return Err(BadInput(format!(
                "{flag}: `{item}` is listed twice (every configuration must differ)"
            )));
        }
        out.push(v);
    }
    Ok(out)
}

fn number(item: &str) -> Result<f64, String> {
    item.parse::<f64>()
        .map_err(|_| "not a number".to_owned())
        .and_then(threshold)
}

/// The cartesian product of the lists, in printed order: model outermost, then split, then
/// merge. A list not given is not swept (the style's value, or `awt` for the model).
pub fn product(lists: &SweepLists) -> Result<Vec<SweepConfig>, BadInput> {
    let models = match &lists.model {
        Some(t) => list("--model", t, SolverKind::parse)?,
        None => vec![SolverKind::Awt],
    };
    let opt_list = |flag: &str, t: &Option<String>| -> Result<Vec<Option<f64>>, BadInput> {
        Ok(match t {
            Some(t) => list(flag, t, number)?.into_iter().map(Some).collect(),
            None => vec![None],
        })
    };
    let mut splits = opt_list("--split", &lists.split)?;
    let mut merges = opt_list("--merge", &lists.merge)?;
    // `--set` axes; `split_threshold` and `merge_velocity` are the lists of `--split`, `--merge`.
    let mut axes: Vec<(&'static str, Vec<f64>)> = Vec::new();
    for text in &lists.set {
        let (name, values) = set_axis(text, &models)?;
        let given = |flag: &str| BadInput(format!("--set {name}: given twice (also {flag})"));
        match name {
            "split_threshold" if lists.split.is_some() => return Err(given("as --split")),
            "merge_velocity" if lists.merge.is_some() => return Err(given("as --merge")),
            "split_threshold" => splits = values.into_iter().map(Some).collect(),
            "merge_velocity" => merges = values.into_iter().map(Some).collect(),
            _ if axes.iter().any(|(n, _)| *n == name) => return Err(given("by another --set")),
            _ => axes.push((name, values)),
        }
    }
    // Every combination of the `--set` axes, first axis outermost.
    let mut combos: Vec<Vec<(&'static str, f64)>> = vec![Vec::new()];
    for (name, values) in &axes {
        combos = combos
            .into_iter()
            .flat_map(|c| {
                values.iter().map(move |&v| {
                    let mut c = c.clone();
                    c.push((*name, v));
                    c
                })
            })
            .collect();
    }
    let mut out = Vec::with_capacity(models.len() * splits.len() * merges.len() * combos.len());
    for &model in &models {
        for &split in &splits {
            for &merge in &merges {
                for sets in &combos {
                    out.push(SweepConfig {
                        label: label_with(model, split, merge, sets),
                        model,
                        split,
                        merge,
                        sets: sets.clone(),
                    });
                }
            }
        }
    }
    if out.is_empty() {
        return Err(BadInput(
            "the sweep has no configuration (every list needs at least one item)".to_owned(),
        ));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// The variants file

// The fields of a variants entry are wrappers around an `Option` (absent: `None`, by
// `Default`) rather than `Option`s, so that the file says `split: 0.1`, not `Some(0.1)`; each
// checks its value while parsing, so that RON reports where a bad one is.

/// A model name in a variants file.
#[derive(Default)]
struct ModelField(Option<SolverKind>);

impl<'de> serde::Deserialize<'de> for ModelField {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        SolverKind::parse(&s)
            .map(|k| ModelField(Some(k)))
            .map_err(|e| serde::de::Error::custom(format!("field `model`: {e}")))
    }
}

/// A threshold in a variants file.
#[derive(Default)]
struct Threshold<const SPLIT: bool>(Option<f64>);

impl<'de, const SPLIT: bool> serde::Deserialize<'de> for Threshold<SPLIT> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = f64::deserialize(d)?;
        let field = if SPLIT { "split" } else { "merge" };
        threshold(v)
            .map(|v| Threshold(Some(v)))
            .map_err(|e| serde::de::Error::custom(format!("field `{field}`: {e}")))
    }
}

/// A label in a variants file.
#[derive(Default)]
struct LabelField(Option<String>);

impl<'de> serde::Deserialize<'de> for LabelField {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        if label_ok(&s) {
            Ok(LabelField(Some(s)))
        } else {
            Err(serde::de::Error::custom(format!(
                "field `label`: `{s}` may only hold letters, digits, `_`, `.` and `-`"
            )))
        }
    }
}

/// One entry of a variants file: `(label: "soft", split: 0.1, merge: 0.05, model: "awt")`;
/// every field optional (model `awt`, thresholds the style's, label made as for the lists).
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields, rename = "variant")]
struct VariantEntry {
    #[serde(default)]
    label: LabelField,
    #[serde(default)]
    model: ModelField,
    #[serde(default)]
    split: Threshold<true>,
    #[serde(default)]
    merge: Threshold<false>,
}

/// Reads a variants file (`--variants FILE.ron`): a RON list of entries.
pub fn read_variants(path: &Path) -> Result<Vec<SweepConfig>, BadInput> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| BadInput(format!("--variants {}: {e}", path.display())))?;
    parse_variants(path, &text)
}

/// Parses variants text; `path` names it in errors (`FILE:line:column: …`).
pub fn parse_variants(path: &Path, text: &str) -> Result<Vec<SweepConfig>, BadInput> {
    let entries: Vec<VariantEntry> =
        ron::Options::default()
            .from_str(text)
            .map_err(|e: ron::error::SpannedError| {
                BadInput(format!(
                    "{}:{}:{}: {}",
                    path.display(),
                    e.span.start.line,
                    e.span.start.col,
                    e.code
                ))
            })?;
    if entries.is_empty() {
        return Err(BadInput(format!(
            "{}: the list of variants is empty",
            path.display()
        )));
    }
    let mut out: Vec<SweepConfig> = Vec::with_capacity(entries.len());
    for (k, e) in entries.into_iter().enumerate() {
        let model = e.model.0.unwrap_or(SolverKind::Awt);
        let (split, merge) = (e.split.0, e.merge.0);
        let label = e.label.0.unwrap_or_else(|| label_of(model, split, merge));
        if let Some(j) = out.iter().position(|c| c.label == label) {
            return Err(BadInput(format!(
                "{}{}: variant {k}: field `label`: `{label}` is already the label of variant {j}",
                path.display(),
                line_of_nth(text, &label, 1)
                    .map(|l| format!(":{l}"))
                    .unwrap_or_default()
            )));
        }
        out.push(SweepConfig {
            label,
            model,
            split,
            merge,
            sets: Vec::new(),
        });
    }
    Ok(out)
}

/// The line (from 1) of the `n`-th (from 0) occurrence of `"needle"` in `text`, if any.
fn line_of_nth(text: &str, needle: &str, n: usize) -> Option<usize> {
    let quoted = format!("\"{needle}\"");
    let (at, _) = text.match_indices(&quoted).nth(n)?;
    Some(text[..at].lines().count().max(1))
}

// ---------------------------------------------------------------------------------------------
// The whole plan

/// Where the configurations come from.
#[derive(Debug, Clone, PartialEq)]
pub enum SweepSource {
    /// The cartesian product of these lists.
    Lists(SweepLists),
    /// Named variants in a RON file.
    Variants(PathBuf),
}

/// The configurations of a sweep, in printed order (`--only K` counts in it from 0).
pub fn configurations(source: &SweepSource) -> Result<Vec<SweepConfig>, BadInput> {
    match source {
        SweepSource::Lists(l) => product(l),
        SweepSource::Variants(p) => read_variants(p),
    }
}

/// The recording id of a sweep: the same for every part of one sweep (`--only K`), different
/// for another sweep, so that `rerun rrd merge part-*.rrd` gives one recording. It hashes
/// `description` (the sweep's arguments without `--only` and the sink: see
/// [`crate::app::sweep::SweepCommand::identity`]) with 64-bit FNV-1a, stable across machines
/// and Rust versions (std's hasher promises neither).
pub fn recording_id(description: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in description.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("wisptree-sweep-{h:016x}")
}
