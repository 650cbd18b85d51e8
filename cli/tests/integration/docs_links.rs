//! Every relative link of the repository's Markdown (README, CHANGELOG,
//! the guide, the benchmarks and records, the scenes' and examples'
//! READMEs) leads to a file that exists, and every `#anchor` to a heading
//! of its page: a section moved or renamed breaks no reader's link.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The Markdown files under `dir`, build outputs and version control aside.
fn markdown_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for path in entries {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if path.is_dir() {
            if !(name.starts_with('.') || name == "target" || name == "node_modules") {
                markdown_files(&path, out);
            }
        } else if name.ends_with(".md") {
            out.push(path);
        }
    }
}

/// The lines of a page outside its fenced code blocks, numbered from 1.
fn prose_lines(text: &str) -> Vec<(usize, &str)> {
    let mut fenced = false;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced {
            out.push((i + 1, line));
        }
    }
    out
}

/// The anchor GitHub gives a heading: lower case, punctuation dropped,
/// spaces as hyphens.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | ' '))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// A page's anchors: each heading's slug, a repeated one numbered as
/// GitHub numbers it (`-1`, `-2`, …).
fn anchors(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (_, line) in prose_lines(text) {
        let level = line.chars().take_while(|&c| c == '#').count();
        if !(1..=6).contains(&level) || !line[level..].starts_with(' ') {
            continue;
        }
        let base = slug(&line[level..]);
        let mut anchor = base.clone();
        let mut k = 0;
        while out.contains(&anchor) {
            k += 1;
            anchor = format!("{base}-{k}");
        }
        out.insert(anchor);
    }
    out
}

/// The targets of a line's inline links `[text](target)`.
fn link_targets(line: &str) -> Vec<&str> {
    line.match_indices("](")
        .filter_map(|(at, _)| {
            let rest = &line[at + 2..];
            let end = rest.find(')')?;
            let target = &rest[..end];
            (!target.is_empty() && !target.contains(char::is_whitespace)).then_some(target)
        })
        .collect()
}

/// The broken links of one page, each as `PAGE:LINE: TARGET (why)`;
/// `anchors_of` holds each linked page's anchors, read once.
fn broken_links(page: &Path, root: &Path, anchors_of: &mut BTreeMap<PathBuf, BTreeSet<String>>) -> Vec<String> {
    let text = std::fs::read_to_string(page).unwrap();
    let shown = page.strip_prefix(root).unwrap_or(page).display().to_string();
    let mut broken = Vec::new();
    for (number, line) in prose_lines(&text) {
        for target in link_targets(line) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = target.split_once('#').map_or((target, None), |(p, a)| (p, Some(a)));
            let file = if path.is_empty() { page.to_path_buf() } else { page.parent().unwrap().join(path) };
            if !file.exists() {
                broken.push(format!("{shown}:{number}: {target} (no such file)"));
                continue;
            }
            let is_page = file.extension().is_some_and(|e| e == "md");
            if let (Some(anchor), true) = (anchor, is_page) {
                let linked = anchors_of
                    .entry(file.canonicalize().unwrap())
                    .or_insert_with(|| anchors(&std::fs::read_to_string(&file).unwrap()));
                if !linked.contains(anchor) {
                    broken.push(format!("{shown}:{number}: {target} (no such heading)"));
                }
            }
        }
    }
    broken
}

#[test]
fn every_relative_link_of_the_docs_leads_to_a_file_and_heading() {
    let root = Path::new(repo_root!()).canonicalize().unwrap();
    let mut pages = Vec::new();
    markdown_files(&root, &mut pages);
    assert!(pages.len() >= 20, "the repository's pages: {pages:?}");
    let mut anchors_of = BTreeMap::new();
    let broken: Vec<String> = pages.iter().flat_map(|p| broken_links(p, &root, &mut anchors_of)).collect();
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn anchors_are_the_headings_as_github_writes_them() {
    let page = "# Dual-stage evaluation (the paper's protocol)\n```sh\n# not a heading\n```\n\
                ### The CBV within the tyres' grip\n## Notes\n## Notes\n#hashtag\n";
    let expected = ["dual-stage-evaluation-the-papers-protocol", "the-cbv-within-the-tyres-grip", "notes", "notes-1"];
    assert_eq!(anchors(page), expected.iter().map(|s| s.to_string()).collect());
    assert_eq!(link_targets("see [a](b.md#c) and [d](e f) or [g](h)"), ["b.md#c", "h"]);
}
