//! docs/architecture.md is true to the workspace: its Mermaid graph names every workspace
//! crate and draws exactly the normal dependencies between them (an arrow `a --> b` for
//! each crate `a` whose `Cargo.toml` depends on `b`; dev-dependencies are not arrows), and
//! its table of crates copies each crate's `Cargo.toml` description word for word. The
//! workspace is read with `cargo metadata --no-deps`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The workspace's crates: each one's description and the workspace crates it depends on
/// (normal dependencies only).
fn workspace() -> BTreeMap<String, (String, BTreeSet<String>)> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .arg("--manifest-path")
        .arg(root().join("Cargo.toml"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = meta["packages"].as_array().unwrap();
    let names: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    packages
        .iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| d["kind"].is_null()) // normal: not "dev", not "build"
                .map(|d| d["name"].as_str().unwrap().to_string())
                .filter(|n| names.contains(n))
                .collect();
            let description = p["description"].as_str().unwrap_or("").to_string();
            (p["name"].as_str().unwrap().to_string(), (description, deps))
        })
        .collect()
}

/// The doc's graph: the crates of its nodes (`id["crate"]`) and its arrows (`a --> b`, by
/// crate name).
fn graph(doc: &str) -> (BTreeSet<String>, BTreeSet<(String, String)>) {
    let block = doc
        .split("```mermaid")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("docs/architecture.md has a ```mermaid block");
    let mut nodes = BTreeMap::new();
    let mut edges = Vec::new();
    for line in block.lines().map(str::trim) {
        if let Some((a, b)) = line.split_once("-->") {
            edges.push((a.trim().to_string(), b.trim().to_string()));
        } else if let Some((id, rest)) = line.split_once("[\"") {
            let name = rest.strip_suffix("\"]").expect("a node is id[\"name\"]");
            assert!(
                nodes.insert(id.to_string(), name.to_string()).is_none(),
                "node {id} twice"
            );
        } else {
            assert!(
                line.is_empty() || line.starts_with("graph "),
                "unread line in the graph: {line}"
            );
        }
    }
    let name = |id: &str| -> String {
        nodes
            .get(id)
            .unwrap_or_else(|| panic!("arrow from or to {id}, which is no node"))
            .clone()
    };
    let arrows: BTreeSet<(String, String)> =
        edges.iter().map(|(a, b)| (name(a), name(b))).collect();
    assert_eq!(arrows.len(), edges.len(), "an arrow is drawn twice");
    let by_name = nodes.values().cloned().collect::<BTreeSet<_>>();
    assert_eq!(by_name.len(), nodes.len(), "a crate is drawn twice");
    (by_name, arrows)
}

#[test]
fn the_architecture_doc_draws_every_crate_and_every_dependency() {
    let ws = workspace();
    assert!(ws.len() >= 10, "the workspace: {:?}", ws.keys());
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let (nodes, arrows) = graph(&doc);
    let drawn: BTreeSet<&String> = nodes.iter().collect();
    let crates: BTreeSet<&String> = ws.keys().collect();
    assert_eq!(
        drawn, crates,
        "the graph's crates (left) are not the workspace's (right)"
    );
    let real: BTreeSet<(String, String)> = ws
        .iter()
        .flat_map(|(a, (_, deps))| deps.iter().map(move |b| (a.clone(), b.clone())))
        .collect();
    let missing: Vec<_> = real.difference(&arrows).collect();
    let extra: Vec<_> = arrows.difference(&real).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "docs/architecture.md's graph: missing arrows {missing:?}, arrows with no dependency {extra:?}"
    );
    // The layering holds: no cycle (a crate's dependencies all come before it).
    let mut placed: BTreeSet<&String> = BTreeSet::new();
    while placed.len() < ws.len() {
        let next: Vec<&String> = ws
            .iter()
            .filter(|(n, (_, deps))| !placed.contains(n) && deps.iter().all(|d| placed.contains(d)))
            .map(|(n, _)| n)
            .collect();
        assert!(!next.is_empty(), "a dependency cycle among {:?}", ws.keys());
        placed.extend(next);
    }
}

#[test]
fn the_architecture_doc_copies_each_crates_description() {
    let ws = workspace();
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    for (name, (description, _)) in &ws {
        assert!(
            !description.is_empty(),
            "{name} has no description in its Cargo.toml"
        );
        let row = format!("| [`{name}`](../crates/{name}/) | {description} |");
        assert!(
            doc.lines().any(|l| l == row),
            "docs/architecture.md has no row\n{row}\n(the crate's Cargo.toml description, word for word)"
        );
    }
}

#[test]
fn the_graph_reader_reads_nodes_and_arrows_by_crate_name() {
    let doc = "```mermaid\ngraph TD\n  a[\"x\"]\n  b[\"y\"]\n  a --> b\n```\n";
    let (nodes, arrows) = graph(doc);
    assert_eq!(nodes.len(), 2);
    assert_eq!(arrows, BTreeSet::from([("x".to_string(), "y".to_string())]));
}
