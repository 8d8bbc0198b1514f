//! `wisptree export --format usd`: one USD layer (`.usda`) of the whole run, for DCC tools
//! (Blender, Houdini, Unreal, Omniverse).
//!
//! * `/wisptree/hair`: one `BasisCurves` prim holding every strand of the model, `linear`, with
//!   the same smoothed points as the `.hair` export (two Catmull-Rom points per span, 2K − 1
//!   per strand). Linear rather than `cubic`/`catmullRom` over the K nodes: the points are then
//!   exactly those of the other formats, and every importer reads linear curves. `points` is
//!   time-sampled at every exported frame (time code = frame number, as `run`'s `frame`
//!   timeline), with `extent`; `curveVertexCounts` and a constant `widths` are written once.
//! * `/wisptree/body`: an `Xform` whose time-sampled matrix is the motion's rigid pose, holding
//!   the collision spheres (`Sphere` at their rest centres) and the scalp (a unit `Sphere`
//!   scaled to the ellipsoid's radii).
//! * `/wisptree/structure` (`--debug-structure`): the model's active nodes as `Points` (a
//!   quarter of their radius, as in the viewer) and segments as linear `BasisCurves` (the child
//!   node's radius, translucent), coloured by level: the AWT paper's Figure 4 display.
//!
//! Points are streamed to a temporary file beside the output as frames are simulated; the few
//! per-frame values written after them (extents, poses, structure) are kept until the end. The
//! temporary file is renamed to the output only once complete, and removed on any error.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::usda::{self, LayerMeta};
use crate::error::BadInput;
use crate::frame::Frame;
use crate::model::HairModel;
use crate::motion::Pose;

/// Width of an exported strand, m: a human hair is 50–100 µm thick.
pub const HAIR_WIDTH: f32 = 7.0e-5;

/// Opacity of the structure's segments (the viewer's capsules are translucent too).
const SEGMENT_OPACITY: f32 = 0.25;

/// The AWT structure of one frame, as drawn.
struct StructureSample {
    time: u64,
    nodes: Vec<[f32; 3]>,
    node_widths: Vec<f32>,
    node_colors: Vec<[f32; 3]>,
    seg_points: Vec<[f32; 3]>,
    seg_widths: Vec<f32>,
    seg_colors: Vec<[f32; 3]>,
}

/// A USD layer being written: open with [`UsdLayer::create`], feed frames, then
/// [`UsdLayer::finish`]. Dropped unfinished, it removes its temporary file.
pub struct UsdLayer {
    path: PathBuf,
    tmp: PathBuf,
    w: Option<BufWriter<File>>,
    /// The temporary file became the output (else it is removed on drop).
    renamed: bool,
    meta: LayerMeta,
    started: bool,
    extents: Vec<(u64, [f32; 3], [f32; 3])>,
    poses: Vec<(u64, Pose)>,
    structure: Option<Vec<StructureSample>>,
    model: std::sync::Arc<HairModel>,
}

/// The message of a failed write: the output's path, exit code 2.
fn cannot_write(path: &Path, e: std::io::Error) -> BadInput {
    BadInput(format!("--out {}: cannot write: {e}", path.display()))
}

impl UsdLayer {
    /// Opens the temporary file beside `path` (its folder is created if needed).
    pub fn create(
        path: &Path,
        meta: LayerMeta,
        model: std::sync::Arc<HairModel>,
        debug_structure: bool,
    ) -> Result<UsdLayer, BadInput> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty());
        if let Some(d) = dir {
            std::fs::create_dir_all(d).map_err(|e| cannot_write(path, e))?;
        }
        let tmp = dir
            .unwrap_or_else(|| Path::new("."))
            .join(format!(".{name}.{}.tmp", std::process::id()));
        let file = File::create(&tmp).map_err(|e| cannot_write(path, e))?;
        Ok(UsdLayer {
            path: path.to_path_buf(),
            tmp,
            w: Some(BufWriter::with_capacity(1 << 20, file)),
            renamed: false,
            meta,
            started: false,
            extents: Vec::new(),
            poses: Vec::new(),
            structure: debug_structure.then(Vec::new),
            model,
        })
    }

    /// Writes one frame (`time` = its frame number): the strands' points now, the rest later.
    pub fn frame(&mut self, time: u64, frame: &Frame, pose: &Pose) -> Result<(), BadInput> {
        self.write_frame(time, frame)
            .map_err(|e| cannot_write(&self.path, e))?;
        self.poses.push((time, *pose));
        if let Some(s) = &mut self.structure {
            s.push(structure_sample(time, frame));
        }
        Ok(())
    }

    fn write_frame(&mut self, time: u64, frame: &Frame) -> std::io::Result<()> {
        let w = self.w.as_mut().expect("an open layer");
        if !self.started {
            self.started = true;
            usda::header(w, &self.meta)?;
            writeln!(w, "def Xform {}", usda::string(&self.meta.default_prim))?;
            writeln!(w, "{{")?;
            writeln!(w, "    def BasisCurves \"hair\"")?;
            writeln!(w, "    {{")?;
            writeln!(w, "        uniform token type = \"linear\"")?;
            writeln!(w, "        uniform token wrap = \"nonperiodic\"")?;
            let counts: Vec<u32> = frame
                .strands
                .offsets
                .windows(2)
                .map(|o| o[1] - o[0])
                .collect();
            write!(w, "        int[] curveVertexCounts = ")?;
            usda::int_array(w, &counts)?;
            writeln!(w)?;
            write!(w, "        float[] widths = [")?;
            usda::num(w, HAIR_WIDTH)?;
            writeln!(w, "] (")?;
            writeln!(w, "            interpolation = \"constant\"")?;
            writeln!(w, "        )")?;
            write!(w, "        color3f[] primvars:displayColor = [")?;
            usda::vec3(w, [0.45, 0.3, 0.15])?;
            writeln!(w, "] (")?;
            writeln!(w, "            interpolation = \"constant\"")?;
            writeln!(w, "        )")?;
            writeln!(w, "        point3f[] points.timeSamples = {{")?;
        }
        write!(w, "            {time}: ")?;
        usda::vec3_array(w, &frame.strands.points)?;
        writeln!(w, ",")?;
        let half = HAIR_WIDTH * 0.5;
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &frame.strands.points {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] - half);
                hi[a] = hi[a].max(p[a] + half);
            }
        }
        self.extents.push((time, lo, hi));
        Ok(())
    }

    /// Writes what was kept (extents, the body, the structure), closes the layer and renames it
    /// to its final name. Returns the bytes written.
    pub fn finish(mut self) -> Result<u64, BadInput> {
        let path = self.path.clone();
        self.write_tail().map_err(|e| cannot_write(&path, e))?;
        let file = self
            .w
            .take()
            .expect("an open layer")
            .into_inner()
            .map_err(|e| cannot_write(&path, e.into_error()))?;
        file.sync_all().map_err(|e| cannot_write(&path, e))?;
        drop(file);
        // Never over a file the user has: an earlier layer is kept as NAME.bak.
        if let Some(bak) =
            crate::files::move_aside(&path).map_err(|e| BadInput(format!("--out: {e}")))?
        {
            eprintln!("kept the earlier {} as {}", path.display(), bak.display());
        }
        std::fs::rename(&self.tmp, &self.path).map_err(|e| cannot_write(&path, e))?;
        self.renamed = true;
        Ok(std::fs::metadata(&self.path).map_or(0, |m| m.len()))
    }

    fn write_tail(&mut self) -> std::io::Result<()> {
        let w = self.w.as_mut().expect("an open layer");
        writeln!(w, "        }}")?;
        writeln!(w, "        float3[] extent.timeSamples = {{")?;
        for (t, lo, hi) in &self.extents {
            write!(w, "            {t}: ")?;
            usda::vec3_array(w, &[*lo, *hi])?;
            writeln!(w, ",")?;
        }
        writeln!(w, "        }}")?;
        writeln!(w, "    }}")?;
        write_body(w, &self.model, &self.poses)?;
        if let Some(s) = &self.structure {
            write_structure(w, s)?;
        }
        writeln!(w, "}}")?;
        w.flush()
    }
}

impl Drop for UsdLayer {
    fn drop(&mut self) {
        drop(self.w.take());
        if !self.renamed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

fn structure_sample(time: u64, f: &Frame) -> StructureSample {
    let color = |l: u16| {
        let (r, g, b) = crate::stream::level_rgb(l, f.levels);
        [r, g, b].map(|c| f32::from(c) / 255.0)
    };
    let n = &f.nodes;
    let s = &f.segments;
    StructureSample {
        time,
        nodes: n.positions.clone(),
        node_widths: n.radii.iter().map(|r| r * 0.5).collect(),
        node_colors: n.levels.iter().map(|&l| color(l)).collect(),
        seg_points: s
            .starts
            .iter()
            .zip(&s.ends)
            .flat_map(|(a, b)| [*a, *b])
            .collect(),
        seg_widths: s.radii.iter().flat_map(|r| [2.0 * r, 2.0 * r]).collect(),
        seg_colors: s.levels.iter().map(|&l| color(l)).collect(),
    }
}

/// The body: an `Xform` moved by the pose, with the spheres and the scalp at rest inside it.
fn write_body(w: &mut impl Write, m: &HairModel, poses: &[(u64, Pose)]) -> std::io::Result<()> {
    writeln!(w, "    def Xform \"body\"")?;
    writeln!(w, "    {{")?;
    writeln!(w, "        matrix4d xformOp:transform.timeSamples = {{")?;
    for (t, pose) in poses {
        let r = pose.iso.rotation.to_rotation_matrix();
        let r = r.matrix();
        let rows = [0, 1, 2].map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]);
        let tr = pose.iso.translation.vector;
        write!(w, "            {t}: ")?;
        usda::matrix4d(w, rows, [tr.x, tr.y, tr.z])?;
        writeln!(w, ",")?;
    }
    writeln!(w, "        }}")?;
    writeln!(
        w,
        "        uniform token[] xformOpOrder = [\"xformOp:transform\"]"
    )?;
    for (i, s) in m.body.iter().enumerate() {
        writeln!(w)?;
        writeln!(w, "        def Sphere \"sphere_{i}\"")?;
        writeln!(w, "        {{")?;
        let r = s.radius;
        writeln!(w, "            double radius = {r:?}")?;
        writeln!(
            w,
            "            float3[] extent = [({:?}, {:?}, {:?}), ({r:?}, {r:?}, {r:?})]",
            -r, -r, -r
        )?;
        let c = s.center;
        writeln!(
            w,
            "            double3 xformOp:translate = ({:?}, {:?}, {:?})",
            c[0], c[1], c[2]
        )?;
        writeln!(
            w,
            "            uniform token[] xformOpOrder = [\"xformOp:translate\"]"
        )?;
        writeln!(w, "        }}")?;
    }
    let (c, r) = (m.scalp_center, m.scalp_radii);
    writeln!(w)?;
    writeln!(w, "        def Sphere \"scalp\"")?;
    writeln!(w, "        {{")?;
    writeln!(w, "            double radius = 1")?;
    writeln!(
        w,
        "            double3 xformOp:translate = ({:?}, {:?}, {:?})",
        c.x, c.y, c.z
    )?;
    writeln!(
        w,
        "            double3 xformOp:scale = ({:?}, {:?}, {:?})",
        r.x, r.y, r.z
    )?;
    writeln!(
        w,
        "            uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:scale\"]"
    )?;
    writeln!(w, "        }}")?;
    writeln!(w, "    }}")
}

/// One time-sampled attribute: `decl.timeSamples = { t: value, … }`.
fn samples<W: Write>(
    w: &mut W,
    decl: &str,
    s: &[StructureSample],
    mut value: impl FnMut(&mut W, &StructureSample) -> std::io::Result<()>,
) -> std::io::Result<()> {
    writeln!(w, "            {decl}.timeSamples = {{")?;
    for x in s {
        write!(w, "                {}: ", x.time)?;
        value(w, x)?;
        writeln!(w, ",")?;
    }
    writeln!(w, "            }}")
}

/// `--debug-structure`: the active nodes and segments of every exported frame.
fn write_structure(w: &mut impl Write, s: &[StructureSample]) -> std::io::Result<()> {
    writeln!(w)?;
    writeln!(w, "    def Scope \"structure\"")?;
    writeln!(w, "    {{")?;
    writeln!(w, "        def Points \"nodes\"")?;
    writeln!(w, "        {{")?;
    samples(w, "point3f[] points", s, |w, x| {
        usda::vec3_array(w, &x.nodes)
    })?;
    samples(w, "float[] widths", s, |w, x| {
        usda::float_array(w, &x.node_widths)
    })?;
    writeln!(w, "            color3f[] primvars:displayColor (")?;
    writeln!(w, "                interpolation = \"vertex\"")?;
    writeln!(w, "            )")?;
    samples(w, "color3f[] primvars:displayColor", s, |w, x| {
        usda::vec3_array(w, &x.node_colors)
    })?;
    writeln!(w, "        }}")?;
    writeln!(w)?;
    writeln!(w, "        def BasisCurves \"segments\"")?;
    writeln!(w, "        {{")?;
    writeln!(w, "            uniform token type = \"linear\"")?;
    samples(w, "int[] curveVertexCounts", s, |w, x| {
        usda::int_array(w, &vec![2; x.seg_points.len() / 2])
    })?;
    samples(w, "point3f[] points", s, |w, x| {
        usda::vec3_array(w, &x.seg_points)
    })?;
    samples(w, "float[] widths", s, |w, x| {
        usda::float_array(w, &x.seg_widths)
    })?;
    writeln!(w, "            color3f[] primvars:displayColor (")?;
    writeln!(w, "                interpolation = \"uniform\"")?;
    writeln!(w, "            )")?;
    samples(w, "color3f[] primvars:displayColor", s, |w, x| {
        usda::vec3_array(w, &x.seg_colors)
    })?;
    write!(w, "            float[] primvars:displayOpacity = [")?;
    usda::num(w, SEGMENT_OPACITY)?;
    writeln!(w, "] (")?;
    writeln!(w, "                interpolation = \"constant\"")?;
    writeln!(w, "            )")?;
    writeln!(w, "        }}")?;
    writeln!(w, "    }}")
}
