//! Where a value sits in a spec file. serde gives typed values but no
//! positions for most of them (and none inside untagged enums), so
//! validation that runs after parsing asks this module instead: the file's
//! YAML is read once more as a tree of nodes with their start positions
//! (granit-parser, the parser under serde-saphyr), and a dotted path such as
//! `acceptance.variant.min_gap_m` or `agents[2].length_m` leads to the node.
//!
//! A path that does not exist (a value left at its default) resolves to its
//! nearest existing ancestor, so an error always points somewhere useful.

use granit_parser::{Event, Parser};

use super::SpecLocation;

/// A YAML node and where it starts.
#[derive(Debug, Clone, PartialEq)]
pub enum Node {
    /// A scalar (or an alias, kept as its name).
    Scalar {
        /// The scalar's text.
        text: String,
        /// Where it starts.
        at: SpecLocation,
    },
    /// A sequence.
    Sequence {
        /// Its items.
        items: Vec<Node>,
        /// Where it starts.
        at: SpecLocation,
    },
    /// A mapping, keys in file order.
    Mapping {
        /// Key–value pairs.
        entries: Vec<(Node, Node)>,
        /// Where it starts.
        at: SpecLocation,
    },
}

/// One step of a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step<'a> {
    /// A mapping key.
    Key(&'a str),
    /// A sequence index.
    Index(usize),
}

impl Node {
    /// Where the node starts.
    pub fn at(&self) -> SpecLocation {
        match self {
            Node::Scalar { at, .. } | Node::Sequence { at, .. } | Node::Mapping { at, .. } => *at,
        }
    }

    /// The scalar text, if this is a scalar.
    pub fn text(&self) -> Option<&str> {
        match self {
            Node::Scalar { text, .. } => Some(text),
            _ => None,
        }
    }

    /// The key node and value of `key`, if this is a mapping holding it.
    pub fn entry(&self, key: &str) -> Option<(&Node, &Node)> {
        match self {
            Node::Mapping { entries, .. } => entries.iter().find(|(k, _)| k.text() == Some(key)).map(|(k, v)| (k, v)),
            _ => None,
        }
    }

    /// The keys of a mapping, in file order (empty for other nodes).
    pub fn keys(&self) -> Vec<(&str, SpecLocation)> {
        match self {
            Node::Mapping { entries, .. } => entries.iter().filter_map(|(k, _)| Some((k.text()?, k.at()))).collect(),
            _ => Vec::new(),
        }
    }

    /// The node one step down, if any.
    pub fn child(&self, step: Step<'_>) -> Option<&Node> {
        match (self, step) {
            (Node::Mapping { .. }, Step::Key(k)) => self.entry(k).map(|(_, v)| v),
            (Node::Sequence { items, .. }, Step::Index(i)) => items.get(i),
            _ => None,
        }
    }

    /// The node at `path`, or the deepest existing ancestor and whether the
    /// whole path was found.
    pub fn walk(&self, path: &[Step<'_>]) -> (&Node, bool) {
        let mut node = self;
        for step in path {
            match node.child(*step) {
                Some(n) => node = n,
                None => return (node, false),
            }
        }
        (node, true)
    }
}

/// Parses a dotted path (`agents[2].length_m`) into steps.
pub fn parse_path(path: &str) -> Vec<Step<'_>> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (key, mut rest) = part.split_once('[').map_or((part, ""), |(k, r)| (k, r));
        if !key.is_empty() {
            out.push(Step::Key(key));
        }
        while let Some((index, after)) = rest.split_once(']') {
            if let Ok(i) = index.parse() {
                out.push(Step::Index(i));
            }
            rest = after.strip_prefix('[').unwrap_or(after);
        }
    }
    out
}

/// The first document of `text` as a tree, or `None` when it is not YAML
/// (the serde parse reports that error with its own location).
pub fn tree(text: &str) -> Option<Node> {
    let mut events = Vec::new();
    for item in Parser::new_from_str(text) {
        let (event, span) = item.ok()?;
        let at = SpecLocation { line: span.start.line() as u64, column: span.start.col() as u64 + 1 };
        events.push((event, at));
    }
    build(&events, &mut 0)
}

/// The node starting at or after `events[*pos]`, advancing `pos` past it.
fn build(events: &[(Event<'_>, SpecLocation)], pos: &mut usize) -> Option<Node> {
    loop {
        let (event, at) = events.get(*pos)?;
        *pos += 1;
        let at = *at;
        return Some(match event {
            Event::Scalar(text, ..) => Node::Scalar { text: text.to_string(), at },
            Event::Alias(id) => Node::Scalar { text: format!("*{id}"), at },
            Event::SequenceStart(..) => {
                let mut items = Vec::new();
                while !at_end(events, pos, |e| matches!(e, Event::SequenceEnd)) {
                    items.push(build(events, pos)?);
                }
                Node::Sequence { items, at }
            }
            Event::MappingStart(..) => {
                let mut entries = Vec::new();
                while !at_end(events, pos, |e| matches!(e, Event::MappingEnd)) {
                    let key = build(events, pos)?;
                    let value = build(events, pos)?;
                    entries.push((key, value));
                }
                Node::Mapping { entries, at }
            }
            // Stream and document markers, anchors and comments carry no value.
            _ => continue,
        });
    }
}

/// Whether the next event closes the collection (consuming it if so).
/// Comments and anchors before it are passed over: a comment after a
/// mapping's last entry (`acceptance:` followed by an indented note) would
/// otherwise be read as the start of another entry, and the close as its
/// value.
fn at_end(events: &[(Event<'_>, SpecLocation)], pos: &mut usize, end: impl Fn(&Event<'_>) -> bool) -> bool {
    while events.get(*pos).is_some_and(|(e, _)| matches!(e, Event::Comment(..) | Event::Anchor(..))) {
        *pos += 1;
    }
    match events.get(*pos) {
        Some((e, _)) if end(e) => {
            *pos += 1;
            true
        }
        Some(_) => false,
        None => true,
    }
}

/// Where `path` is in `text`: the value's position, or the nearest existing
/// ancestor's when the path is absent.
pub fn locate(text: &str, path: &str) -> Option<SpecLocation> {
    let root = tree(text)?;
    Some(root.walk(&parse_path(path)).0.at())
}

/// For a key written twice in one mapping, the place of its first
/// occurrence, given the place of the second (where the YAML parser stops).
pub fn first_occurrence_of_key_at(text: &str, second: SpecLocation) -> Option<SpecLocation> {
    fn search(node: &Node, second: SpecLocation) -> Option<SpecLocation> {
        match node {
            Node::Scalar { .. } => None,
            Node::Sequence { items, .. } => items.iter().find_map(|n| search(n, second)),
            Node::Mapping { entries, .. } => {
                if let Some((key, _)) = entries.iter().find(|(k, _)| k.at() == second) {
                    let first = entries.iter().find(|(k, _)| k.text().is_some() && k.text() == key.text())?;
                    return (first.0.at() != second).then(|| first.0.at());
                }
                entries.iter().find_map(|(_, v)| search(v, second))
            }
        }
    }
    search(&tree(text)?, second)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SUITE: &str = "name: s\nscenarios:\n  - a.yaml\n  - recorded: data:x\n    limt: 1\nacceptance:\n  variant: { no_collision: true, min_gap_m: .nan }\nagents:\n  - { id: a, length_m: -4 }\n  - id: b\n    length_m: 0\n";

    fn at(line: u64, column: u64) -> Option<SpecLocation> {
        Some(SpecLocation { line, column })
    }

    #[test]
    fn paths_find_block_and_flow_values() {
        assert_eq!(locate(SUITE, "acceptance.variant.min_gap_m"), at(7, 45));
        assert_eq!(locate(SUITE, "agents[0].length_m"), at(9, 24));
        assert_eq!(locate(SUITE, "agents[1].length_m"), at(11, 15));
        assert_eq!(locate(SUITE, "scenarios[1].limt"), at(5, 11));
        assert_eq!(locate(SUITE, "scenarios[0]"), at(3, 5));
    }

    #[test]
    fn an_absent_path_points_at_its_nearest_ancestor() {
        assert_eq!(locate(SUITE, "acceptance.suite.solution_rate_min"), at(7, 3));
        assert_eq!(locate(SUITE, "variants"), at(1, 1));
    }

    #[test]
    fn keys_come_with_their_own_positions() {
        let root = tree(SUITE).unwrap();
        let entry = root.walk(&parse_path("scenarios[1]")).0;
        assert_eq!(
            entry.keys(),
            vec![("recorded", SpecLocation { line: 4, column: 5 }), ("limt", SpecLocation { line: 5, column: 5 })]
        );
    }

    #[test]
    fn the_first_of_a_duplicated_key_is_found_from_the_second() {
        let text = "a: 1\nb:\n  x: 1\n  y: 2\n  x: 3\n";
        assert_eq!(first_occurrence_of_key_at(text, SpecLocation { line: 5, column: 3 }), at(3, 3));
        assert_eq!(first_occurrence_of_key_at(text, SpecLocation { line: 3, column: 3 }), None);
    }

    #[test]
    fn path_syntax() {
        assert_eq!(
            parse_path("a.b[2][3].c"),
            vec![Step::Key("a"), Step::Key("b"), Step::Index(2), Step::Index(3), Step::Key("c")]
        );
    }

    #[test]
    fn a_comment_after_a_mappings_last_entry_does_not_lose_the_places() {
        let text =
            "scenarios:\n  - recorded: data:x\nacceptance:\n  variant: { no_off_road: true }\n  # a note\n  # more\n";
        assert_eq!(locate(text, "scenarios[0].recorded"), Some(SpecLocation { line: 2, column: 15 }));
        assert_eq!(locate(text, "acceptance.variant.no_off_road"), Some(SpecLocation { line: 4, column: 27 }));
    }
}
