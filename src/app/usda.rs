//! The small part of USD's text format (`.usda`) that `export --format usd` writes: layer
//! metadata, nested `def` blocks, uniform and time-sampled attributes of numbers, vectors,
//! arrays of them and 4×4 matrices. The grammar is Pixar's "USD file format" text syntax; the
//! tests read what this writes back with Pixar's own reader (`usd-core`).
//!
//! Numbers are written in their shortest form that reads back to the same `f32`/`f64`, so a
//! reader gets exactly the values wisptree holds.

use std::io::{self, Write};

/// Layer metadata: the stage's units, axis and time range.
#[derive(Debug, Clone)]
pub struct LayerMeta {
    /// The root prim a reference to the layer picks up.
    pub default_prim: String,
    /// A line saying where the layer came from.
    pub doc: String,
    /// First and last time code written (frame numbers).
    pub start: f64,
    /// Last time code.
    pub end: f64,
    /// Time codes per second: the frame rate, since a time code is a frame number.
    pub fps: f64,
}

/// Writes the layer header: `#usda 1.0` and the metadata block (y up, metres).
pub fn header(w: &mut impl Write, m: &LayerMeta) -> io::Result<()> {
    writeln!(w, "#usda 1.0")?;
    writeln!(w, "(")?;
    writeln!(w, "    defaultPrim = {}", string(&m.default_prim))?;
    writeln!(w, "    doc = {}", string(&m.doc))?;
    writeln!(w, "    endTimeCode = {:?}", m.end)?;
    writeln!(w, "    framesPerSecond = {:?}", m.fps)?;
    writeln!(w, "    metersPerUnit = 1")?;
    writeln!(w, "    startTimeCode = {:?}", m.start)?;
    writeln!(w, "    timeCodesPerSecond = {:?}", m.fps)?;
    writeln!(w, "    upAxis = \"Y\"")?;
    writeln!(w, ")")?;
    writeln!(w)
}

/// A quoted string literal, with `"`, `\` and line breaks escaped.
pub fn string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A prim name made of what USD allows (letters, digits, `_`; not starting with a digit).
pub fn identifier(s: &str) -> String {
    let mut out: String = s
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

/// One `f32`, shortest round-trip form (`1.0`, `0.25`, `1e-5`); non-finite values as USD
/// spells them.
pub fn num(w: &mut impl Write, x: f32) -> io::Result<()> {
    if x.is_finite() {
        write!(w, "{x:?}")
    } else if x.is_nan() {
        w.write_all(b"nan")
    } else if x > 0.0 {
        w.write_all(b"inf")
    } else {
        w.write_all(b"-inf")
    }
}

/// `(x, y, z)`.
pub fn vec3(w: &mut impl Write, p: [f32; 3]) -> io::Result<()> {
    w.write_all(b"(")?;
    num(w, p[0])?;
    w.write_all(b", ")?;
    num(w, p[1])?;
    w.write_all(b", ")?;
    num(w, p[2])?;
    w.write_all(b")")
}

/// `[(x, y, z), …]`.
pub fn vec3_array(w: &mut impl Write, points: &[[f32; 3]]) -> io::Result<()> {
    w.write_all(b"[")?;
    for (i, p) in points.iter().enumerate() {
        if i > 0 {
            w.write_all(b", ")?;
        }
        vec3(w, *p)?;
    }
    w.write_all(b"]")
}

/// `[a, b, …]` of `f32`.
pub fn float_array(w: &mut impl Write, xs: &[f32]) -> io::Result<()> {
    w.write_all(b"[")?;
    for (i, x) in xs.iter().enumerate() {
        if i > 0 {
            w.write_all(b", ")?;
        }
        num(w, *x)?;
    }
    w.write_all(b"]")
}

/// `[a, b, …]` of integers.
pub fn int_array(w: &mut impl Write, xs: &[u32]) -> io::Result<()> {
    w.write_all(b"[")?;
    for (i, x) in xs.iter().enumerate() {
        if i > 0 {
            w.write_all(b", ")?;
        }
        write!(w, "{x}")?;
    }
    w.write_all(b"]")
}

/// A `matrix4d` in USD's row-vector convention (`p' = p · M`, translation in the last row),
/// from a rotation `r` (row-major, acting on column vectors) and a translation `t`.
pub fn matrix4d(w: &mut impl Write, r: [[f64; 3]; 3], t: [f64; 3]) -> io::Result<()> {
    // Row i of M is column i of r, so that p · M equals r · p.
    let columns = [0, 1, 2].map(|i| [r[0][i], r[1][i], r[2][i]]);
    write!(w, "( ")?;
    for c in columns {
        write!(w, "({:?}, {:?}, {:?}, 0), ", c[0], c[1], c[2])?;
    }
    write!(w, "({:?}, {:?}, {:?}, 1) )", t[0], t[1], t[2])
}

/// The size in bytes of `vec3` at its longest: a sign, nine significant digits, a point and an
/// exponent (`-1.2345679e-5`, `-0.00012345679`) take at most 15 characters a number.
pub const MAX_VEC3_BYTES: u64 = 1 + 3 * 15 + 2 * 2 + 1;

#[cfg(test)]
mod tests {
    use super::*;

    fn text(f: impl FnOnce(&mut Vec<u8>) -> io::Result<()>) -> String {
        let mut v = Vec::new();
        f(&mut v).unwrap();
        String::from_utf8(v).unwrap()
    }

    #[test]
    fn numbers_read_back_exactly_and_stay_short() {
        for x in [
            0.1f32,
            -1.6,
            1e-5,
            -1.2345679e-5,
            -0.00012345679,
            123.45679,
            f32::MIN_POSITIVE,
        ] {
            let s = text(|w| num(w, x));
            assert_eq!(s.parse::<f32>().unwrap(), x, "{s}");
            assert!(s.len() <= 15, "{s}");
        }
        assert_eq!(text(|w| num(w, f32::NAN)), "nan");
        assert_eq!(
            text(|w| vec3_array(w, &[[1.0, 2.0, 3.0], [0.5, 0.0, -1.0]])),
            "[(1.0, 2.0, 3.0), (0.5, 0.0, -1.0)]"
        );
    }

    #[test]
    fn names_and_strings_are_escaped() {
        assert_eq!(identifier("side left-1"), "side_left_1");
        assert_eq!(identifier("3d"), "_3d");
        assert_eq!(string("a \"b\"\n"), "\"a \\\"b\\\"\\n\"");
    }

    #[test]
    fn a_matrix_puts_the_translation_in_the_last_row() {
        let r = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let s = text(|w| matrix4d(w, r, [1.0, 2.0, 3.0]));
        assert_eq!(
            s,
            "( (0.0, 1.0, 0.0, 0), (-1.0, 0.0, 0.0, 0), (0.0, 0.0, 1.0, 0), (1.0, 2.0, 3.0, 1) )"
        );
    }
}
