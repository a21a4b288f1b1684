//! The layers of docs/architecture.md §1, enforced on the source: every `crate::`, `super::` and
//! `self::` path of every file under `src/` (outside `#[cfg(test)]` items), resolved through the
//! modules' re-exports to the file that defines what it names, must point to a layer at or below
//! the importing file's own, and no two files may import each other through any chain of imports
//! (a file and its own parent or child module excepted: a module's `mod.rs` and its files are one
//! unit that Rust asks to name each other), nor may two top-level modules (`src/a.rs` with
//! `src/a/`) import each other through any chain.
//!
//! The layer table is read from the document itself, between the `layers` markers, so the
//! document and the rule cannot drift apart.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

/// A module path from the crate root, e.g. ["model", "params"]; the root is [].
type ModPath = Vec<String>;

/// One `src/**.rs` file of the library.
struct SourceFile {
    path: PathBuf,
    module: ModPath,
    /// `use` paths and absolute paths found in the file, each made absolute.
    imports: Vec<ModPath>,
    /// Names this module re-exports (`pub use a::b::C;` → "C" → a::b::C), absolute.
    reexports: HashMap<String, ModPath>,
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// src/a/b.rs → a::b, src/a/mod.rs → a, src/lib.rs → the root.
fn module_of(src: &Path, file: &Path) -> ModPath {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: ModPath = rel
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|p| p == "mod" || p == "lib") {
        parts.pop();
    }
    parts
}

fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && a.parse_args::<syn::Meta>()
                .is_ok_and(|m| m.path().is_ident("test"))
    })
}

/// Collects a file's paths, skipping `#[cfg(test)]` items.
struct Paths<'a> {
    module: &'a ModPath,
    children: &'a BTreeSet<String>,
    imports: Vec<ModPath>,
    reexports: HashMap<String, ModPath>,
}

impl Paths<'_> {
    /// Makes a path absolute if it starts with `crate`, `super`, `self` or (in a `use`) a child
    /// module of this file; None for a path into another crate or a local name.
    fn absolute(&self, segments: &[String], in_use: bool) -> Option<ModPath> {
        let first = segments.first()?;
        let mut base = match first.as_str() {
            "crate" => ModPath::new(),
            "self" => self.module.clone(),
            "super" => {
                let mut b = self.module.clone();
                let mut rest = segments;
                while rest.first().is_some_and(|s| s == "super") {
                    b.pop();
                    rest = &rest[1..];
                }
                b.extend(rest.iter().cloned());
                return Some(b);
            }
            name if in_use && self.children.contains(name) => {
                let mut b = self.module.clone();
                b.push(name.to_string());
                b.extend(segments[1..].iter().cloned());
                return Some(b);
            }
            _ => return None,
        };
        base.extend(segments[1..].iter().cloned());
        Some(base)
    }

    fn use_tree(&mut self, tree: &syn::UseTree, prefix: &mut Vec<String>, public: bool) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.use_tree(&p.tree, prefix, public);
                prefix.pop();
            }
            syn::UseTree::Name(n) => self.use_leaf(prefix, &n.ident.to_string(), None, public),
            syn::UseTree::Rename(r) => self.use_leaf(
                prefix,
                &r.ident.to_string(),
                Some(r.rename.to_string()),
                public,
            ),
            syn::UseTree::Glob(_) => {
                if let Some(p) = self.absolute(prefix, true) {
                    self.imports.push(p);
                }
            }
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.use_tree(t, prefix, public);
                }
            }
        }
    }

    fn use_leaf(&mut self, prefix: &[String], name: &str, alias: Option<String>, public: bool) {
        let mut segments = prefix.to_vec();
        if name != "self" {
            segments.push(name.to_string());
        }
        if let Some(p) = self.absolute(&segments, true) {
            if public {
                let visible = alias.unwrap_or_else(|| segments.last().unwrap().clone());
                self.reexports.insert(visible, p.clone());
            }
            self.imports.push(p);
        }
    }
}

impl<'ast> Visit<'ast> for Paths<'_> {
    fn visit_item(&mut self, item: &'ast syn::Item) {
        let attrs = match item {
            syn::Item::Mod(m) => &m.attrs,
            syn::Item::Fn(f) => &f.attrs,
            syn::Item::Use(u) => &u.attrs,
            syn::Item::Impl(i) => &i.attrs,
            syn::Item::Const(c) => &c.attrs,
            syn::Item::Static(s) => &s.attrs,
            syn::Item::Struct(s) => &s.attrs,
            syn::Item::Enum(e) => &e.attrs,
            _ => return syn::visit::visit_item(self, item),
        };
        if is_cfg_test(attrs) {
            return;
        }
        if let syn::Item::Use(u) = item {
            let public = !matches!(u.vis, syn::Visibility::Inherited);
            self.use_tree(&u.tree, &mut Vec::new(), public);
            return;
        }
        syn::visit::visit_item(self, item);
    }

    fn visit_path(&mut self, path: &'ast syn::Path) {
        let segments: Vec<String> = path.segments.iter().map(|s| s.ident.to_string()).collect();
        if segments.len() > 1 {
            if let Some(p) = self.absolute(&segments, false) {
                self.imports.push(p);
            }
        }
        syn::visit::visit_path(self, path);
    }
}

fn read_sources() -> Vec<SourceFile> {
    let src = root().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    // main.rs is the command's own crate: it reaches the library as `lobe::`, never `crate::`.
    files.retain(|f| f != &src.join("main.rs"));
    let modules: BTreeSet<ModPath> = files.iter().map(|f| module_of(&src, f)).collect();
    let texts: Vec<(PathBuf, ModPath, String)> = files
        .into_iter()
        .map(|path| {
            let text = std::fs::read_to_string(&path).unwrap();
            let module = module_of(&src, &path);
            (path, module, text)
        })
        .collect();
    // Files of modules declared `#[cfg(test)] mod name;` are tests, as a `#[cfg(test)]` item is.
    let tests: Vec<ModPath> = texts
        .iter()
        .flat_map(|(path, module, text)| test_modules(path, module, text))
        .collect();
    texts
        .into_iter()
        .filter(|(_, module, _)| !tests.iter().any(|t| module.starts_with(t)))
        .map(|(path, module, text)| parse_source(path, module, &text, &modules))
        .collect()
}

/// The child modules a file declares under `#[cfg(test)]` (`#[cfg(test)] mod tests;`).
fn test_modules(path: &Path, module: &ModPath, text: &str) -> Vec<ModPath> {
    let ast =
        syn::parse_file(text).unwrap_or_else(|e| panic!("{}: not parsed: {e}", path.display()));
    ast.items
        .iter()
        .filter_map(|item| match item {
            syn::Item::Mod(m) if is_cfg_test(&m.attrs) => {
                let mut child = module.clone();
                child.push(m.ident.to_string());
                Some(child)
            }
            _ => None,
        })
        .collect()
}

fn parse_source(
    path: PathBuf,
    module: ModPath,
    text: &str,
    modules: &BTreeSet<ModPath>,
) -> SourceFile {
    let children = modules
        .iter()
        .filter(|m| m.len() == module.len() + 1 && m.starts_with(&module))
        .map(|m| m.last().unwrap().clone())
        .collect();
    let ast =
        syn::parse_file(text).unwrap_or_else(|e| panic!("{}: not parsed: {e}", path.display()));
    let mut paths = Paths {
        module: &module,
        children: &children,
        imports: Vec::new(),
        reexports: HashMap::new(),
    };
    paths.visit_file(&ast);
    let (imports, reexports) = (paths.imports, paths.reexports);
    SourceFile {
        path,
        module,
        imports,
        reexports,
    }
}

/// The file that defines what `path` names: the deepest module file on the way, following
/// re-exports (`pub use`) to where the item is defined.
fn resolve(path: &[String], files: &BTreeMap<ModPath, &SourceFile>, depth: usize) -> ModPath {
    let mut module = ModPath::new();
    for (i, segment) in path.iter().enumerate() {
        let mut child = module.clone();
        child.push(segment.clone());
        if files.contains_key(&child) {
            module = child;
            continue;
        }
        if let Some(target) = files[&module].reexports.get(segment) {
            if depth < 8 && target.as_slice() != path {
                let mut full = target.clone();
                full.extend(path[i + 1..].iter().cloned());
                return resolve(&full, files, depth + 1);
            }
        }
        break;
    }
    module
}

/// One layer of the table: its number, its name and the module paths it holds.
struct Layer {
    level: usize,
    name: String,
    modules: Vec<ModPath>,
}

/// Reads the table between `<!-- layers -->` and `<!-- /layers -->` in docs/architecture.md: one
/// line per layer, `L<n> <name>: module, module::file, ...` (`crate` is the root, lib.rs).
fn layer_table() -> Vec<Layer> {
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let start = doc
        .find("<!-- layers -->")
        .expect("docs/architecture.md: no layers table");
    let end = doc
        .find("<!-- /layers -->")
        .expect("docs/architecture.md: layers table not closed");
    doc[start..end]
        .lines()
        .filter_map(|line| {
            let line = line.trim();
            let rest = line.strip_prefix('L')?;
            let (head, modules) = rest.split_once(':')?;
            let (level, name) = head.split_once(' ')?;
            Some(Layer {
                level: level.parse().ok()?,
                name: name.trim().to_string(),
                modules: modules
                    .split(',')
                    .map(|m| m.trim())
                    .filter(|m| !m.is_empty())
                    .map(|m| match m {
                        "crate" => ModPath::new(),
                        m => m.split("::").map(str::to_string).collect(),
                    })
                    .collect(),
            })
        })
        .collect()
}

/// The layer of a module: the table's longest module path that contains it.
fn layer_of<'a>(module: &ModPath, layers: &'a [Layer]) -> Option<&'a Layer> {
    layers
        .iter()
        .flat_map(|l| l.modules.iter().map(move |m| (l, m)))
        .filter(|(_, m)| {
            if m.is_empty() {
                module.is_empty()
            } else {
                module.starts_with(m)
            }
        })
        .max_by_key(|(_, m)| m.len())
        .map(|(l, _)| l)
}

fn shown(m: &ModPath) -> String {
    if m.is_empty() {
        "crate".to_string()
    } else {
        m.join("::")
    }
}

/// The import graph between files: importer → (imported file → the path written).
type Graph = BTreeMap<ModPath, BTreeMap<ModPath, ModPath>>;

fn import_graph(files: &[SourceFile]) -> Graph {
    let by_module: BTreeMap<ModPath, &SourceFile> =
        files.iter().map(|f| (f.module.clone(), f)).collect();
    let mut graph = Graph::new();
    for file in files {
        let edges = graph.entry(file.module.clone()).or_default();
        for import in &file.imports {
            let target = resolve(import, &by_module, 0);
            if target != file.module {
                edges.entry(target).or_insert_with(|| import.clone());
            }
        }
    }
    graph
}

/// Back-imports: a file importing from a layer above its own, as "file imports path (layer)".
fn back_imports(graph: &Graph, layers: &[Layer]) -> Vec<String> {
    let mut found = Vec::new();
    for (from, edges) in graph {
        let Some(own) = layer_of(from, layers) else {
            continue;
        };
        for (to, written) in edges {
            let Some(theirs) = layer_of(to, layers) else {
                continue;
            };
            if theirs.level > own.level {
                found.push(format!(
                    "{} (L{} {}) imports crate::{} (L{} {})",
                    shown(from),
                    own.level,
                    own.name,
                    shown(written),
                    theirs.level,
                    theirs.name
                ));
            }
        }
    }
    found
}

/// Import circles between files, each as "a → b → … → a"; an edge between a module and its own
/// parent or child is not part of any circle.
fn circles(graph: &Graph) -> Vec<String> {
    let related = |a: &ModPath, b: &ModPath| a.starts_with(b) || b.starts_with(a);
    let edges: BTreeMap<&ModPath, Vec<&ModPath>> = graph
        .iter()
        .map(|(from, e)| (from, e.keys().filter(|to| !related(from, to)).collect()))
        .collect();
    // Tarjan's strongly connected components, iteratively small enough to recurse.
    struct State<'a> {
        edges: &'a BTreeMap<&'a ModPath, Vec<&'a ModPath>>,
        index: HashMap<&'a ModPath, usize>,
        low: HashMap<&'a ModPath, usize>,
        stack: Vec<&'a ModPath>,
        components: Vec<Vec<&'a ModPath>>,
    }
    fn connect<'a>(s: &mut State<'a>, v: &'a ModPath) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        for &w in s.edges.get(v).map(Vec::as_slice).unwrap_or(&[]) {
            if !s.index.contains_key(w) {
                connect(s, w);
                let lw = s.low[w];
                s.low.insert(v, s.low[v].min(lw));
            } else if s.stack.contains(&w) {
                let iw = s.index[w];
                s.low.insert(v, s.low[v].min(iw));
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                component.push(w);
                if w == v {
                    break;
                }
            }
            s.components.push(component);
        }
    }
    let mut state = State {
        edges: &edges,
        index: HashMap::new(),
        low: HashMap::new(),
        stack: Vec::new(),
        components: Vec::new(),
    };
    for v in edges.keys() {
        if !state.index.contains_key(*v) {
            connect(&mut state, v);
        }
    }
    let mut found: Vec<String> = state
        .components
        .iter()
        .filter(|c| c.len() > 1)
        .map(|c| {
            let mut names: Vec<String> = c.iter().map(|m| shown(m)).collect();
            names.sort();
            names.join(" ↔ ")
        })
        .collect();
    found.sort();
    found
}

/// The import graph between top-level modules (`src/a.rs` and everything under `src/a/` are
/// `a`): an edge where any file of one imports a file of the other. The crate root (lib.rs, the
/// facade that re-exports the public names) is left out: imports through it resolve to the
/// files that define what they name.
fn module_graph(graph: &Graph) -> Graph {
    let top = |m: &ModPath| m.first().map(|s| vec![s.clone()]);
    let mut modules = Graph::new();
    for (from, edges) in graph {
        let Some(a) = top(from) else { continue };
        let out = modules.entry(a.clone()).or_default();
        for (to, written) in edges {
            match top(to) {
                Some(b) if b != a => {
                    out.entry(b).or_insert_with(|| written.clone());
                }
                _ => {}
            }
        }
    }
    modules
}

#[test]
fn every_file_imports_only_its_own_layer_and_below() {
    let layers = layer_table();
    assert!(
        layers.len() >= 5,
        "docs/architecture.md: layers table too short"
    );
    let files = read_sources();
    let unplaced: Vec<String> = files
        .iter()
        .filter(|f| layer_of(&f.module, &layers).is_none())
        .map(|f| f.path.display().to_string())
        .collect();
    assert!(
        unplaced.is_empty(),
        "files in no layer of docs/architecture.md's table: {unplaced:?}"
    );
    let found = back_imports(&import_graph(&files), &layers);
    assert!(
        found.is_empty(),
        "imports from a layer above (docs/architecture.md §1):\n{}",
        found.join("\n")
    );
}

#[test]
fn no_files_import_each_other_in_a_circle() {
    let found = circles(&import_graph(&read_sources()));
    assert!(
        found.is_empty(),
        "files that import each other through a chain of imports:\n{}",
        found.join("\n")
    );
}

#[test]
fn no_top_level_modules_import_each_other_in_a_circle() {
    let graph = module_graph(&import_graph(&read_sources()));
    let found = circles(&graph);
    let example = |c: &String| {
        let names: Vec<&str> = c.split(" ↔ ").collect();
        names
            .iter()
            .flat_map(|a| names.iter().map(move |b| (*a, *b)))
            .filter_map(|(a, b)| {
                let written = graph.get(&vec![a.to_string()])?.get(&vec![b.to_string()])?;
                Some(format!("  {a} imports crate::{}", shown(written)))
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert!(
        found.is_empty(),
        "top-level modules that import each other through a chain of imports:\n{}",
        found
            .iter()
            .map(|c| format!("{c}\n{}", example(c)))
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// The module rule finds a circle that no two files make: `grid` importing a model's file is no
/// file circle (the model's file does not import grid.rs back), but `model` as a whole imports
/// `grid` (its files take directions from it), so the two modules import each other.
#[test]
fn a_planted_circle_between_modules_is_found() {
    let mut files = read_sources();
    let modules: BTreeSet<ModPath> = files.iter().map(|f| f.module.clone()).collect();
    let grid = vec!["grid".to_string()];
    let model = vec!["model".to_string()];
    let before = module_graph(&import_graph(&files));
    assert!(
        before[&model].contains_key(&grid),
        "model no longer imports grid: plant another circle"
    );
    let planted = parse_source(
        PathBuf::from("src/grid/mod.rs"),
        grid.clone(),
        "use crate::model::ParamSet;\nfn f(_: &ParamSet) {}",
        &modules,
    );
    files.retain(|f| f.module != grid);
    files.push(planted);
    let found = circles(&module_graph(&import_graph(&files)));
    assert!(
        found
            .iter()
            .any(|c| c.contains("grid") && c.contains("model")),
        "{found:?}"
    );
}

/// The two rules find what they are for: a core file that imports the session's `Table` (a layer
/// far above, whose file imports it back) is reported as a back-import and as a circle.
#[test]
fn a_planted_back_import_and_circle_are_found() {
    let layers = layer_table();
    let mut files = read_sources();
    let modules: BTreeSet<ModPath> = files.iter().map(|f| f.module.clone()).collect();
    let grid = vec!["grid".to_string()];
    let planted = parse_source(
        PathBuf::from("src/grid/mod.rs"),
        grid.clone(),
        "use crate::session::Table;\nfn f(_: &Table) {}",
        &modules,
    );
    assert!(
        import_graph(&files)[&vec!["session".to_string(), "table".to_string()]].contains_key(&grid),
        "the session no longer imports grid: plant another circle"
    );
    files.retain(|f| f.module != grid);
    files.push(planted);
    let graph = import_graph(&files);
    let back = back_imports(&graph, &layers);
    assert!(
        back.iter()
            .any(|b| b.starts_with("grid ") && b.contains("crate::session::Table")),
        "{back:?}"
    );
    let found = circles(&graph);
    assert!(
        found
            .iter()
            .any(|c| c.contains("grid") && c.contains("session")),
        "{found:?}"
    );
}
