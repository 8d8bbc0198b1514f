//! `wisptree inspect STYLE`: the model a style builds, in numbers.

use crate::model::HairModel;
use crate::style::builtin::StyleSource;
use crate::style::{self, Link};

/// `wisptree inspect` arguments.
#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    /// The style: a built-in name (see `wisptree styles`) or a `.ron` file.
    pub style: String,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// How much of the scalp the hair at rest hides, seen from above, behind, left and right:
    /// renders each view with the scalp alone as the body and prints the percentage of
    /// hair-bearing scalp pixels (within 10 mm of a root) that the hair hides, one line per view
    #[arg(long)]
    pub coverage: bool,
    /// With --coverage: image size, WIDTHxHEIGHT pixels (as `wisptree render`'s, which frames
    /// the hair the same way: a strand is as wide as in its pictures)
    #[arg(long, value_name = "WxH", default_value = "640x480", value_parser = super::args::parse_size)]
    pub size: (u32, u32),
    /// With --coverage: also write each view's render into this folder (`coverage_top.png`, …)
    #[arg(long, value_name = "DIR")]
    pub images: Option<std::path::PathBuf>,
}

/// Summary numbers of a model, as `inspect --json` prints them.
#[derive(Debug, serde::Serialize)]
#[allow(missing_docs)] // the JSON keys, each named for what it holds
pub struct ModelSummary {
    pub style: String,
    pub levels: usize,
    pub gcs_per_level: Vec<usize>,
    pub nodes_per_level: Vec<usize>,
    pub strands: usize,
    pub cross_sections: usize,
    pub total_mass_kg: f64,
    pub radius_min_m: f64,
    pub radius_max_m: f64,
    pub max_strand_length_m: f64,
    pub link: String,
    pub trees: usize,
    /// [`HairModel::point_hash`] as 16 hex digits: equal for styles that build the same hair.
    pub model_hash: String,
}

/// The numbers `inspect` prints.
pub fn summarize(loaded: &style::LoadedStyle, m: &HairModel) -> ModelSummary {
    let (rmin, rmax) = m.radius_range();
    ModelSummary {
        style: loaded.path.display().to_string(),
        levels: m.level_count(),
        gcs_per_level: m.levels.iter().map(|l| l.gc_count()).collect(),
        nodes_per_level: (0..m.level_count()).map(|l| m.nodes_on_level(l)).collect(),
        strands: m.strands.len(),
        cross_sections: m.k,
        total_mass_kg: m.levels[0].mass.iter().sum(),
        radius_min_m: rmin,
        radius_max_m: rmax,
        max_strand_length_m: m.max_strand_length(),
        link: match m.link {
            Link::Rigid { .. } => "rigid".into(),
            Link::Spring { .. } => "spring".into(),
        },
        trees: m.levels[0].gc_count(),
        model_hash: format!("{:016x}", m.point_hash()),
    }
}

/// `wisptree inspect`.
pub fn inspect(a: &InspectArgs) -> anyhow::Result<()> {
    let source = StyleSource::parse(&a.style);
    let (loaded, model) = crate::scene::load_model(&source)?;
    for n in &model.notes {
        eprintln!("wisptree: note: {n}");
    }
    for w in crate::scene::warnings(&model) {
        eprintln!("warning: {w}");
    }
    if a.coverage {
        return coverage(a, &loaded, &model);
    }
    if a.images.is_some() {
        return Err(crate::error::BadInput("--images needs --coverage".into()).into());
    }
    let s = summarize(&loaded, &model);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&s)?);
        return Ok(());
    }
    println!("style        {}", s.style);
    println!("level   GCs    nodes");
    for l in 0..s.levels {
        println!(
            "{l:>5} {:>5} {:>8}",
            s.gcs_per_level[l], s.nodes_per_level[l]
        );
    }
    println!("strands      {}", s.strands);
    println!("total mass   {:.4} kg", s.total_mass_kg);
    println!(
        "radius       {:.2} – {:.1} mm",
        s.radius_min_m * 1e3,
        s.radius_max_m * 1e3
    );
    println!("K            {} cross-sections per GC", s.cross_sections);
    println!("longest      {:.3} m", s.max_strand_length_m);
    println!("link         {}", s.link);
    println!("model hash   {} (every strand point at rest)", s.model_hash);
    Ok(())
}

/// `wisptree inspect --coverage`.
fn coverage(a: &InspectArgs, loaded: &style::LoadedStyle, model: &HairModel) -> anyhow::Result<()> {
    if let Some(dir) = &a.images {
        std::fs::create_dir_all(dir).map_err(|e| {
            crate::error::BadInput(format!(
                "--images {}: cannot create the folder: {e}",
                dir.display()
            ))
        })?;
    }
    let views =
        crate::app::coverage::of_model(model, &loaded.style.render, a.size, a.images.as_deref())?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&views)?);
        return Ok(());
    }
    println!(
        "scalp hidden by the hair at rest ({}):",
        loaded.path.display()
    );
    for v in &views {
        println!("{:<7} {:5.1} %", v.view, v.hidden_percent);
    }
    Ok(())
}
