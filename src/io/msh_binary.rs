//! Binary MSH 4.1: translated to the equivalent ASCII text, which the
//! readers already check line by line. Binary files are what Gmsh writes
//! for large meshes; the translation keeps one reader of the format's
//! meaning, and costs a copy.
//!
//! Layout (Gmsh's reference manual, "MSH file format", version 4.1 with
//! file-type 1 and data-size 8): after `4.1 1 8` comes the integer 1 in the
//! writer's byte order; `$Entities`, `$Nodes` and `$Elements` hold `int`
//! (4 bytes) and `size_t` (8 bytes) fields and `double`s in that order, as
//! in the ASCII layout; other sections are text.

use super::msh::MshError;
use std::fmt::Write;

/// Nodes per element of the MSH types a binary element block may hold
/// (the blocks carry no node count, so an unknown type cannot be skipped).
fn nodes_per_element(ty: i32) -> Option<usize> {
    Some(match ty {
        1 => 2,
        2 => 3,
        3 => 4,
        4 => 4,
        5 => 8,
        6 => 6,
        7 => 5,
        8 => 3,
        9 => 6,
        10 => 9,
        11 => 10,
        12 => 27,
        15 => 1,
        16 => 8,
        17 => 20,
        26 => 4,
        27 => 5,
        36 => 16,
        37 => 25,
        92 => 64,
        93 => 125,
        _ => return None,
    })
}

/// True when `bytes` start like a binary MSH 4.1 file.
pub fn is_binary(bytes: &[u8]) -> bool {
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(64)]);
    let mut t = head.split_whitespace();
    t.next() == Some("$MeshFormat") && t.next() == Some("4.1") && t.next() == Some("1")
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    swap: bool,
}

impl<'a> Reader<'a> {
    /// The 1-based line the reader is on (counting newline bytes, which
    /// inside binary data is only approximate, but names the section).
    fn line(&self) -> usize {
        self.bytes[..self.pos.min(self.bytes.len())].iter().filter(|&&b| b == b'\n').count() + 1
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], MshError> {
        if self.pos + n > self.bytes.len() {
            return Err(MshError::Truncated { line: self.line(), expected: what.to_string() });
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn int(&mut self, what: &str) -> Result<i32, MshError> {
        let b: [u8; 4] = self.take(4, what)?.try_into().expect("4 bytes");
        Ok(if self.swap { i32::from_be_bytes(b) } else { i32::from_le_bytes(b) })
    }

    fn size(&mut self, what: &str) -> Result<u64, MshError> {
        let b: [u8; 8] = self.take(8, what)?.try_into().expect("8 bytes");
        Ok(if self.swap { u64::from_be_bytes(b) } else { u64::from_le_bytes(b) })
    }

    fn double(&mut self, what: &str) -> Result<f64, MshError> {
        let b: [u8; 8] = self.take(8, what)?.try_into().expect("8 bytes");
        Ok(if self.swap { f64::from_be_bytes(b) } else { f64::from_le_bytes(b) })
    }

    /// A count that must fit what is left of the file (each item at least
    /// `min_bytes`), so a damaged count cannot ask for huge allocations.
    fn count(&mut self, what: &str, min_bytes: usize) -> Result<usize, MshError> {
        let n = self.size(what)?;
        let left = (self.bytes.len() - self.pos) as u64;
        if n.saturating_mul(min_bytes as u64) > left {
            return Err(MshError::Truncated { line: self.line(), expected: format!("{n} × {what}") });
        }
        Ok(n as usize)
    }

    /// The text up to and including the next newline.
    fn text_line(&mut self) -> Result<&'a str, MshError> {
        let rest = &self.bytes[self.pos..];
        let end = rest.iter().position(|&b| b == b'\n').map_or(rest.len(), |k| k + 1);
        self.pos += end;
        std::str::from_utf8(&rest[..end]).map_err(|_| MshError::Syntax { line: self.line(), expected: "text".into(), found: "binary data".into() })
    }

    fn skip_newline(&mut self) {
        while self.pos < self.bytes.len() && (self.bytes[self.pos] == b'\n' || self.bytes[self.pos] == b'\r') {
            self.pos += 1;
        }
    }
}

/// The ASCII MSH 4.1 text of a binary MSH 4.1 file.
pub fn binary_to_ascii(bytes: &[u8]) -> Result<String, MshError> {
    let mut r = Reader { bytes, pos: 0, swap: false };
    let mut out = String::new();
    // $MeshFormat, the version line, then the binary 1
    let first = r.text_line()?;
    if first.trim() != "$MeshFormat" {
        return Err(MshError::Syntax { line: 1, expected: "$MeshFormat".into(), found: first.trim().to_string() });
    }
    let version = r.text_line()?.to_string();
    let fields: Vec<&str> = version.split_whitespace().collect();
    if fields.get(2) != Some(&"8") {
        return Err(MshError::Syntax { line: 2, expected: "data size 8".into(), found: version.trim().to_string() });
    }
    let one: [u8; 4] = r.take(4, "the binary integer 1")?.try_into().expect("4 bytes");
    r.swap = match (i32::from_le_bytes(one), i32::from_be_bytes(one)) {
        (1, _) => false,
        (_, 1) => true,
        _ => return Err(MshError::Syntax { line: 3, expected: "the integer 1 in binary".into(), found: format!("{one:?}") }),
    };
    r.skip_newline();
    let _ = writeln!(out, "$MeshFormat\n4.1 0 8");
    loop {
        if r.pos >= bytes.len() {
            break;
        }
        let line = r.text_line()?.trim().to_string();
        if line.is_empty() {
            continue;
        }
        let _ = writeln!(out, "{line}");
        match line.as_str() {
            "$Entities" => entities(&mut r, &mut out)?,
            "$Nodes" => nodes(&mut r, &mut out)?,
            "$Elements" => elements(&mut r, &mut out)?,
            "$PhysicalNames" | "$MeshFormat" => continue,
            s if s.starts_with("$End") => continue,
            s if s.starts_with('$') => {
                // other sections ($Periodic, $PartitionedEntities, data)
                // may hold binary data: skip to their end marker, which
                // the readers skip in any case
                out.pop();
                out.truncate(out.rfind('\n').map_or(0, |k| k + 1));
                let end = format!("$End{}", &s[1..]);
                let rest = &bytes[r.pos..];
                let at = rest.windows(end.len()).position(|w| w == end.as_bytes()).ok_or_else(|| MshError::Truncated { line: r.line(), expected: format!("{end} (binary section {s})") })?;
                r.pos += at + end.len();
                continue;
            }
            _ => continue,
        }
        r.skip_newline();
    }
    Ok(out)
}

fn entities(r: &mut Reader, out: &mut String) -> Result<(), MshError> {
    let counts: Vec<usize> = (0..4).map(|d| r.count(&format!("the number of dimension-{d} entities"), 4)).collect::<Result<_, _>>()?;
    let _ = writeln!(out, "{} {} {} {}", counts[0], counts[1], counts[2], counts[3]);
    for (dim, &n) in counts.iter().enumerate() {
        for _ in 0..n {
            let tag = r.int("an entity tag")?;
            let boxes = if dim == 0 { 3 } else { 6 };
            let coords: Vec<f64> = (0..boxes).map(|_| r.double("an entity bounding box")).collect::<Result<_, _>>()?;
            let np = r.count("the number of physical tags", 4)?;
            let phys: Vec<i32> = (0..np).map(|_| r.int("a physical tag")).collect::<Result<_, _>>()?;
            let _ = write!(out, "{tag}");
            for c in &coords {
                let _ = write!(out, " {c:e}");
            }
            let _ = write!(out, " {np}");
            for p in &phys {
                let _ = write!(out, " {p}");
            }
            if dim > 0 {
                let nb = r.count("the number of bounding entities", 4)?;
                let _ = write!(out, " {nb}");
                for _ in 0..nb {
                    let _ = write!(out, " {}", r.int("a bounding entity")?);
                }
            }
            out.push('\n');
        }
    }
    Ok(())
}

fn nodes(r: &mut Reader, out: &mut String) -> Result<(), MshError> {
    let blocks = r.count("the number of node blocks", 20)?;
    let (total, lo, hi) = (r.size("the number of nodes")?, r.size("the minimum node tag")?, r.size("the maximum node tag")?);
    let _ = writeln!(out, "{blocks} {total} {lo} {hi}");
    for _ in 0..blocks {
        let (dim, tag, parametric) = (r.int("an entity dimension")?, r.int("an entity tag")?, r.int("the parametric flag")?);
        let n = r.count("the number of nodes in a block", 32)?;
        let _ = writeln!(out, "{dim} {tag} {parametric} {n}");
        for _ in 0..n {
            let _ = writeln!(out, "{}", r.size("a node tag")?);
        }
        let per = 3 + if parametric != 0 { dim.clamp(0, 3) as usize } else { 0 };
        for _ in 0..n {
            let x: Vec<f64> = (0..per).map(|_| r.double("a node coordinate")).collect::<Result<_, _>>()?;
            let text: Vec<String> = x.iter().map(|v| if v.is_finite() { format!("{v:e}") } else { "nan".into() }).collect();
            let _ = writeln!(out, "{}", text.join(" "));
        }
    }
    Ok(())
}

fn elements(r: &mut Reader, out: &mut String) -> Result<(), MshError> {
    let blocks = r.count("the number of element blocks", 20)?;
    let (total, lo, hi) = (r.size("the number of elements")?, r.size("the minimum element tag")?, r.size("the maximum element tag")?);
    let _ = writeln!(out, "{blocks} {total} {lo} {hi}");
    for _ in 0..blocks {
        let (dim, tag, ty) = (r.int("an entity dimension")?, r.int("an entity tag")?, r.int("an element type")?);
        // the line is only counted for an error: counting is a scan
        let per = nodes_per_element(ty).ok_or_else(|| MshError::UnknownElementType {
            line: r.line(),
            accepted: "in binary files: points, lines (orders 1-4), quads (orders 1-4), hexahedra (orders 1-4), and linear or quadratic triangles, tetrahedra, prisms and pyramids",
            element_type: ty as i64,
        })?;
        let n = r.count("the number of elements in a block", 8 * (per + 1))?;
        let _ = writeln!(out, "{dim} {tag} {ty} {n}");
        for _ in 0..n {
            let _ = write!(out, "{}", r.size("an element tag")?);
            for _ in 0..per {
                let _ = write!(out, " {}", r.size("a node tag")?);
            }
            out.push('\n');
        }
    }
    Ok(())
}
