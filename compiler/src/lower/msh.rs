//! A reader for Gmsh 4.1 ASCII `.msh` files: nodes, elements, physical groups.

use std::collections::HashMap;

/// An element as read.
#[derive(Clone, Debug, PartialEq)]
pub struct MshElement {
    /// Gmsh element type (1 line, 2 triangle, 3 quadrangle, 4 tetrahedron, 5 hexahedron, 15 point).
    pub etype: u32,
    /// Dimension of the entity the element belongs to.
    pub entity_dim: i32,
    /// Tag of the entity.
    pub entity_tag: i32,
    /// Node tags.
    pub nodes: Vec<usize>,
}

/// The content of a `.msh` file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MshData {
    /// Node tag → coordinates.
    pub nodes: HashMap<usize, [f64; 3]>,
    /// Elements in file order.
    pub elements: Vec<MshElement>,
    /// Physical groups: (dimension, tag, name).
    pub physical_names: Vec<(i32, i32, String)>,
    /// Physical tags of each entity `(dim, tag)`.
    pub entity_physicals: HashMap<(i32, i32), Vec<i32>>,
}

/// A reading error at a 1-based line.
#[derive(Clone, Debug, PartialEq)]
pub struct MshError {
    /// Line number (1-based).
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

/// Gmsh element-type names (for messages).
pub fn type_name(t: u32) -> String {
    match t {
        1 => "line2".into(),
        2 => "tri3".into(),
        3 => "quad4".into(),
        4 => "tet4".into(),
        5 => "hex8".into(),
        15 => "point".into(),
        8 => "line3".into(),
        9 => "tri6".into(),
        10 => "quad9".into(),
        11 => "tet10".into(),
        16 => "quad8".into(),
        17 => "hex20".into(),
        t => format!("type {t}"),
    }
}

/// The most nodes a mesh may have.
pub const MAX_NODES: usize = 50_000_000;

struct Lines<'t> {
    lines: Vec<(usize, Vec<&'t str>)>,
    pos: usize,
}

impl<'t> Lines<'t> {
    fn new(text: &'t str) -> Self {
        let lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.split_whitespace().collect::<Vec<_>>()))
            .filter(|(_, t)| !t.is_empty())
            .collect();
        Lines { lines, pos: 0 }
    }
    fn next(&mut self, what: &str) -> Result<(usize, Vec<&'t str>), MshError> {
        let last = self.lines.last().map(|l| l.0).unwrap_or(1);
        let l = self.lines.get(self.pos).cloned().ok_or(MshError {
            line: last,
            message: format!("unexpected end of file, expected {what}"),
        })?;
        self.pos += 1;
        Ok(l)
    }

    /// The number of lines not read yet.
    fn remaining(&self) -> usize {
        self.lines.len() - self.pos
    }

    /// Checks a count read at `line` against what the rest of the file can hold: each item
    /// takes at least a line, so a count larger than the lines left is refused before
    /// anything is allocated or read for it.
    fn check_count(&self, n: usize, line: usize, what: &str) -> Result<usize, MshError> {
        let left = self.remaining();
        if n > left {
            return Err(MshError {
                line,
                message: format!(
                    "the file says {n} {what}, but only {left} lines follow (each needs a line)"
                ),
            });
        }
        Ok(n)
    }
}

fn num<T: std::str::FromStr>(tok: Option<&&str>, line: usize, what: &str) -> Result<T, MshError> {
    tok.and_then(|s| s.parse::<T>().ok()).ok_or(MshError {
        line,
        message: format!("expected {what}"),
    })
}

/// Parses a Gmsh 4.1 ASCII mesh.
pub fn parse(text: &str) -> Result<MshData, MshError> {
    let mut l = Lines::new(text);
    let mut out = MshData::default();
    let mut saw_format = false;
    let mut saw_nodes = false;
    while l.pos < l.lines.len() {
        let (ln, toks) = l.next("a section")?;
        let head = toks[0];
        if !head.starts_with('$') {
            return Err(MshError {
                line: ln,
                message: format!("expected a section header like `$Nodes`, found `{head}`"),
            });
        }
        let name = &head[1..];
        match name {
            "MeshFormat" => {
                let (ln2, t) = l.next("the format line")?;
                let version: f64 = num(t.first(), ln2, "a version number")?;
                let ftype: i32 = num(t.get(1), ln2, "a file type")?;
                if !(4.0..5.0).contains(&version) || (version - 4.1).abs() > 1e-9 {
                    return Err(MshError {
                        line: ln2,
                        message: format!("only Gmsh format 4.1 is read, this file is version {version} (export with `-format msh41`)"),
                    });
                }
                if ftype != 0 {
                    return Err(MshError {
                        line: ln2,
                        message: "binary .msh files are not read; export as ASCII".into(),
                    });
                }
                saw_format = true;
            }
            "PhysicalNames" => {
                let (ln2, t) = l.next("the number of physical names")?;
                let n: usize = num(t.first(), ln2, "a count")?;
                let n = l.check_count(n, ln2, "physical names")?;
                for _ in 0..n {
                    let (lp, t) = l.next("a physical name")?;
                    let dim: i32 = num(t.first(), lp, "a dimension")?;
                    let tag: i32 = num(t.get(1), lp, "a tag")?;
                    let rest = t.get(2..).map(|r| r.join(" ")).unwrap_or_default();
                    let name = rest.trim_matches('"').to_string();
                    out.physical_names.push((dim, tag, name));
                }
            }
            "Entities" => {
                let (ln2, t) = l.next("entity counts")?;
                let mut counts = [0usize; 4];
                for (i, c) in counts.iter_mut().enumerate() {
                    *c = num(t.get(i), ln2, "an entity count")?;
                }
                let all = counts.iter().fold(0usize, |a, &c| a.saturating_add(c));
                l.check_count(all, ln2, "entities")?;
                for (dim, count) in counts.iter().enumerate() {
                    for _ in 0..*count {
                        let (le, t) = l.next("an entity")?;
                        let tag: i32 = num(t.first(), le, "an entity tag")?;
                        // points: tag x y z nphys ...; others: tag 6 bounds nphys ...
                        let k = if dim == 0 { 4 } else { 7 };
                        let nphys: usize = num(t.get(k), le, "a number of physical tags")?;
                        let on_line = t.len().saturating_sub(k + 1);
                        if nphys > on_line {
                            return Err(MshError {
                                line: le,
                                message: format!(
                                    "the entity says {nphys} physical tags, but the line has {on_line}"
                                ),
                            });
                        }
                        let mut phys = Vec::with_capacity(nphys);
                        for j in 0..nphys {
                            phys.push(num::<i32>(t.get(k + 1 + j), le, "a physical tag")?);
                        }
                        out.entity_physicals.insert((dim as i32, tag), phys);
                    }
                }
            }
            "Nodes" => {
                let (ln2, t) = l.next("node counts")?;
                let blocks: usize = num(t.first(), ln2, "a block count")?;
                let total: usize = num(t.get(1), ln2, "a node count")?;
                if total > MAX_NODES {
                    return Err(MshError {
                        line: ln2,
                        message: format!("{total} nodes is more than the {MAX_NODES} mbdc reads"),
                    });
                }
                // a block takes a header line; a node its tag and its coordinates
                l.check_count(blocks, ln2, "node blocks")?;
                l.check_count(total, ln2, "nodes")?;
                for _ in 0..blocks {
                    let (lb, t) = l.next("a node block")?;
                    let edim: usize = num(t.first(), lb, "an entity dimension")?;
                    let parametric: i32 = num(t.get(2), lb, "the parametric flag")?;
                    let n: usize = num(t.get(3), lb, "a node count")?;
                    let n = l.check_count(n, lb, "nodes in this block")?;
                    let mut tags = Vec::with_capacity(n.min(total));
                    while tags.len() < n {
                        let (lt, t) = l.next("node tags")?;
                        for tok in &t {
                            tags.push(num::<usize>(Some(tok), lt, "a node tag")?);
                        }
                    }
                    for tag in tags {
                        let (lc, t) = l.next("node coordinates")?;
                        let need = 3 + if parametric == 1 { edim } else { 0 };
                        if t.len() < need.min(3) {
                            return Err(MshError {
                                line: lc,
                                message: "expected x y z".into(),
                            });
                        }
                        let x: f64 = num(t.first(), lc, "x")?;
                        let y: f64 = num(t.get(1), lc, "y")?;
                        let z: f64 = num(t.get(2), lc, "z")?;
                        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                            return Err(MshError {
                                line: lc,
                                message: "coordinates must be finite".into(),
                            });
                        }
                        out.nodes.insert(tag, [x, y, z]);
                    }
                }
                saw_nodes = true;
            }
            "Elements" => {
                let (ln2, t) = l.next("element counts")?;
                let blocks: usize = num(t.first(), ln2, "a block count")?;
                l.check_count(blocks, ln2, "element blocks")?;
                for _ in 0..blocks {
                    let (lb, t) = l.next("an element block")?;
                    let edim: i32 = num(t.first(), lb, "an entity dimension")?;
                    let etag: i32 = num(t.get(1), lb, "an entity tag")?;
                    let etype: u32 = num(t.get(2), lb, "an element type")?;
                    let n: usize = num(t.get(3), lb, "an element count")?;
                    let n = l.check_count(n, lb, "elements in this block")?;
                    for _ in 0..n {
                        let (le, t) = l.next("an element")?;
                        if t.len() < 2 {
                            return Err(MshError {
                                line: le,
                                message: "expected an element tag and its nodes".into(),
                            });
                        }
                        let mut nodes = Vec::with_capacity(t.len() - 1);
                        for tok in &t[1..] {
                            nodes.push(num::<usize>(Some(tok), le, "a node tag")?);
                        }
                        out.elements.push(MshElement {
                            etype,
                            entity_dim: edim,
                            entity_tag: etag,
                            nodes,
                        });
                    }
                }
            }
            _ => {}
        }
        // Skip to the end marker.
        let end = format!("$End{name}");
        loop {
            let (_, t) = l.next(&format!("`{end}`"))?;
            if t[0] == end {
                break;
            }
        }
    }
    if !saw_format {
        return Err(MshError {
            line: 1,
            message: "not a Gmsh file: no `$MeshFormat` section".into(),
        });
    }
    if !saw_nodes {
        return Err(MshError {
            line: 1,
            message: "the file has no `$Nodes` section".into(),
        });
    }
    for e in &out.elements {
        if let Some(missing) = e.nodes.iter().find(|n| !out.nodes.contains_key(n)) {
            return Err(MshError {
                line: 1,
                message: format!("an element refers to node {missing}, which is not defined"),
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    pub const SQUARE: &str = r#"$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
1 1 "left"
2 2 "plate"
$EndPhysicalNames
$Entities
0 1 1 0
1 0 0 0 0 1 0 1 1 0 0
1 0 0 0 1 1 0 1 2 0
$EndEntities
$Nodes
2 4 1 4
1 1 0 2
1
4
0 0 0
0 1 0
2 1 0 2
2
3
1 0 0
1 1 0
$EndNodes
$Elements
2 2 1 2
1 1 1 1
1 1 4
2 1 3 1
2 1 2 3 4
$EndElements
"#;

    #[test]
    fn reads_square() {
        let m = parse(SQUARE).unwrap();
        assert_eq!(m.nodes.len(), 4);
        assert_eq!(m.elements.len(), 2);
        assert_eq!(m.elements[1].nodes, vec![1, 2, 3, 4]);
        assert_eq!(m.physical_names[0], (1, 1, "left".into()));
        assert_eq!(m.entity_physicals[&(1, 1)], vec![1]);
    }

    /// An absurd count is refused with its line before anything is allocated for it (it
    /// used to abort the process: a physical-tag count of 10^17 asked for 4·10^17 bytes).
    #[test]
    fn absurd_counts_are_refused_with_their_line() {
        let huge = "99999999999999999";
        let cases = [
            // (the file, the line of the count, words of the message)
            (
                SQUARE.replace("1 0 0 0 1 1 0 1 2 0", &format!("1 0 0 0 1 1 0 {huge} 2 0")),
                12,
                "physical tags",
            ),
            (
                SQUARE.replace("$PhysicalNames\n2\n", &format!("$PhysicalNames\n{huge}\n")),
                5,
                "physical names",
            ),
            (
                SQUARE.replace("0 1 1 0\n", &format!("0 1 {huge} 0\n")),
                10,
                "entities",
            ),
            (
                SQUARE.replace("2 4 1 4\n", &format!("2 {huge} 1 4\n")),
                15,
                "nodes",
            ),
            (
                SQUARE.replace("2 4 1 4\n", &format!("{huge} 4 1 4\n")),
                15,
                "node blocks",
            ),
            (
                SQUARE.replace("1 1 0 2\n", &format!("1 1 0 {huge}\n")),
                16,
                "nodes in this block",
            ),
            (
                SQUARE.replace("2 2 1 2\n", &format!("{huge} 2 1 2\n")),
                28,
                "element blocks",
            ),
            (
                SQUARE.replace("1 1 1 1\n", &format!("1 1 1 {huge}\n")),
                29,
                "elements in this block",
            ),
        ];
        for (text, line, what) in cases {
            assert_ne!(text, SQUARE, "the case for {what} changed nothing");
            let e = parse(&text).unwrap_err();
            assert_eq!(e.line, line, "{what}: {e:?}");
            assert!(e.message.contains(what), "{what}: {e:?}");
        }
        let e = parse(&SQUARE.replace("2 4 1 4\n", "2 60000000 1 4\n")).unwrap_err();
        assert!(e.message.contains("more than the 50000000"), "{e:?}");
    }

    #[test]
    fn errors() {
        assert!(parse("").is_err());
        let e = parse("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n").unwrap_err();
        assert!(e.message.contains("4.1"));
        assert!(parse("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 1 1 1\n1 1 0 1\n").is_err());
    }
}
