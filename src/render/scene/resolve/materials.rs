//! The material phases: which materials the objects use, their channels, the graph files the
//! texture channels bind (each checked once per set of overrides), the outputs they read, and,
//! once everything checks, the compiled textures, the materials and their evaluation groups.

use super::{finite, join_normalised, transform_of, vec3, Binding, Chosen, Resolver};
use crate::check::CheckOptions;
use crate::compile::{compile, CompileOptions};
use crate::diagnostic::{Diagnostic, DiagnosticClass as C, Diagnostics};
use crate::graph::{CheckedGraph, Output, Type};
use crate::load::load_graph;
use crate::precision::Extent;
use crate::render::error::RenderError;
use crate::render::scene::desc::{BumpDesc, ChannelDesc, HeightDesc, Space};
use crate::render::scene::diagnostics::{Key, Problems};
use crate::render::scene::resolved::{Bump, Channel, CompiledTexture, EvalGroup, Material};
use crate::source::LoadError;
use glam::{Affine3A, Mat3, Vec3};
use std::collections::BTreeMap;
use std::path::Path;

impl<'a> Resolver<'a> {
    /// Records the materials the objects use, in order of first use; an unknown name is a
    /// problem.
    pub(super) fn material_uses(&mut self) {
        let desc = self.desc;
        for (i, object) in desc.objects.iter().enumerate() {
            let name = object.material.as_str();
            if desc.materials.contains_key(name) {
                if !self.used.contains(&name) {
                    self.used.push(name);
                }
            } else {
                let known: Vec<&str> = desc.materials.keys().map(|k| k.as_str()).collect();
                let help = match crate::nodes::suggest_from(name, known.iter().copied()) {
                    Some(s) => format!("did you mean \"{s}\"?"),
                    None if known.is_empty() => {
                        "the scene has no materials: add `materials: { \"name\": Material(...) }`"
                            .into()
                    }
                    None => format!("its materials are: {}", known.join(", ")),
                };
                self.problems.add(
                    C::UnknownReference,
                    &[Key::Field("objects"), Key::Index(i), Key::Field("material")],
                    format!("object {}: no material named \"{name}\"", i + 1),
                    Some(help),
                );
            }
        }
    }

    /// Checks the channels of the used materials: constants are kept, textures become
    /// bindings.
    pub(super) fn channels(&mut self) {
        let desc = self.desc;
        for name in self.used.clone() {
            let m = &desc.materials[name];
            let channels: [(&'static str, Option<&ChannelDesc>, bool); 4] = [
                ("ambient", m.ambient.as_ref(), false),
                ("diffuse", Some(&m.diffuse), false),
                ("specular", Some(&m.specular), false),
                ("shininess", Some(&m.shininess), true),
            ];
            for (channel, c, scalar) in channels {
                match c {
                    None => {}
                    Some(ChannelDesc::Colour(r, g, b)) => {
                        self.colour_channel(name, channel, [*r, *g, *b], scalar)
                    }
                    Some(ChannelDesc::Value(v)) => self.value_channel(name, channel, *v, scalar),
                    Some(ChannelDesc::Texture {
                        graph,
                        output,
                        set,
                        space,
                        transform,
                        multiply,
                    }) => self.texture_channel(Binding {
                        material: name,
                        channel,
                        graph,
                        output: output.as_deref(),
                        set,
                        space: *space,
                        transform,
                        multiply: *multiply,
                        scalar,
                        strength: 1.0,
                        short: false,
                    }),
                }
            }
            if let Some(bump) = &m.bump {
                self.bump(name, bump);
            }
        }
    }

    /// Checks material `name`'s bump (its strength, the form of its height) and keeps its
    /// height as a binding.
    fn bump(&mut self, name: &'a str, bump: &'a BumpDesc) {
        static NO_SET: BTreeMap<String, f64> = BTreeMap::new();
        let at = |tail: &'static str| {
            [
                Key::Field("materials"),
                Key::Entry(name),
                Key::Field("bump"),
                Key::Field(tail),
            ]
        };
        let multiply = match &bump.height {
            HeightDesc::Texture(t) if finite(&[t.multiply]) => t.multiply,
            _ => 1.0,
        };
        if !finite(&[bump.strength]) || !finite(&[bump.strength * multiply]) {
            self.problems.add(
                C::BadParameter,
                &at("strength"),
                format!(
                    "material \"{name}\": `bump`: `strength` is {}; it must be finite{}",
                    bump.strength,
                    if multiply == 1.0 {
                        ""
                    } else {
                        ", also times the height's `multiply`"
                    }
                ),
                None,
            );
        }
        let binding = |graph, output, set, space, transform, multiply, short| Binding {
            material: name,
            channel: "bump",
            graph,
            output,
            set,
            space,
            transform,
            multiply,
            scalar: true,
            strength: bump.strength,
            short,
        };
        match &bump.height {
            HeightDesc::Output(text) => match text.rsplit_once('.') {
                Some((graph, output)) if !graph.is_empty() && !output.is_empty() => self
                    .texture_channel(binding(
                        graph,
                        Some(output),
                        &NO_SET,
                        Space::Object,
                        &[],
                        1.0,
                        true,
                    )),
                _ => self.problems.add(
                    C::BadParameter,
                    &at("height"),
                    format!(
                        "material \"{name}\": `bump`: `height` is \"{text}\"; it must name a graph file and its output, \"FILE.OUTPUT\""
                    ),
                    Some("such as \"stone.ron.height\" (split at the last dot), or write Texture(graph: \"stone.ron\", output: \"height\")".into()),
                ),
            },
            HeightDesc::Texture(t) => {
                self.height_form(name);
                self.texture_channel(binding(
                    &t.graph,
                    t.output.as_deref(),
                    &t.set,
                    t.space,
                    &t.transform,
                    t.multiply,
                    false,
                ))
            }
        }
    }

    /// Checks that a bump's height in the `Texture(...)` form is written with that name (the
    /// reader takes any struct there).
    fn height_form(&mut self, name: &'a str) {
        let at = [
            Key::Field("materials"),
            Key::Entry(name),
            Key::Field("bump"),
            Key::Field("height"),
        ];
        let Some(value) = self.problems.value_at(&at) else {
            return;
        };
        let written = match &value.kind {
            crate::syntax::ValueKind::Struct { name: Some(n), .. } if n.value == "Texture" => {
                return
            }
            crate::syntax::ValueKind::Struct { name: Some(n), .. } => format!("`{}(...)`", n.value),
            other => other.describe(),
        };
        self.problems.add(
            C::UnknownKind,
            &at,
            format!(
                "material \"{name}\": `bump`: `height` is {written}; it must be a string \"FILE.OUTPUT\" or `Texture(graph: ..., ...)`"
            ),
            None,
        );
    }

    /// Checks and keeps a `Colour(r, g, b)` channel (a problem in a scalar channel).
    fn colour_channel(
        &mut self,
        name: &'a str,
        channel: &'static str,
        rgb: [f64; 3],
        scalar: bool,
    ) {
        let at = [
            Key::Field("materials"),
            Key::Entry(name),
            Key::Field(channel),
        ];
        if scalar {
            self.problems.add(
                C::Type,
                &at,
                format!("material \"{name}\": `{channel}` is a number, not a colour"),
                Some(format!("write `{channel}: Value(...)`")),
            );
        } else if !finite(&rgb) {
            self.problems.add(
                C::BadParameter,
                &at,
                format!("material \"{name}\": `{channel}` must be finite"),
                None,
            );
        }
        self.constants.push((name, channel, vec3(rgb)));
    }

    /// Checks and keeps a `Value(v)` channel (a grey in a colour channel).
    fn value_channel(&mut self, name: &'a str, channel: &'static str, v: f64, scalar: bool) {
        if !finite(&[v]) || (scalar && v < 0.0) {
            self.problems.add(
                C::BadParameter,
                &[
                    Key::Field("materials"),
                    Key::Entry(name),
                    Key::Field(channel),
                ],
                format!(
                    "material \"{name}\": `{channel}` must be finite{}",
                    if scalar { " and not negative" } else { "" }
                ),
                None,
            );
        }
        self.constants.push((name, channel, Vec3::splat(v as f32)));
    }

    /// Checks a `Texture(...)` channel's overrides, factor and transform, and keeps its binding.
    fn texture_channel(&mut self, b: Binding<'a>) {
        let (name, channel) = (b.material, b.channel);
        if let Some((bad, message)) = b
            .set
            .iter()
            .find(|(_, v)| !v.is_finite())
            .map(|(k, _)| (k, "must be finite".to_string()))
        {
            self.problems.add(
                C::BadParameter,
                &b.at(&[Key::Field("set"), Key::Entry(bad)]),
                format!("material \"{name}\": `{channel}`: param \"{bad}\" {message}"),
                None,
            );
        }
        if !finite(&[b.multiply]) {
            self.problems.add(
                C::BadParameter,
                &b.at(&[Key::Field("multiply")]),
                format!("material \"{name}\": `{channel}`: `multiply` must be finite"),
                None,
            );
        }
        if let Err((step, message)) = transform_of(b.transform) {
            self.problems.add(
                C::BadParameter,
                &b.at(&[Key::Field("transform"), Key::Index(step)]),
                format!("material \"{name}\": `{channel}`: {message}"),
                None,
            );
        }
        self.bindings.push(b);
    }

    /// Collects each (graph file, overrides) the bindings use and checks each graph once.
    pub(super) fn graphs(&mut self) {
        for b in &self.bindings {
            let key = b.key(self.base);
            if !self.keys.contains(&key) {
                self.keys.push(key);
            }
        }
        for k in 0..self.keys.len() {
            let graph = self.graph(k);
            self.graphs.push(graph);
        }
    }

    /// Loads and checks the graph of key `k` with its overrides, reporting its problems against
    /// the first binding that uses it.
    fn graph(&mut self, k: usize) -> Option<CheckedGraph> {
        let path = self.keys[k].0.clone();
        if !self.files.contains(&path) {
            self.files.push(path.clone());
        }
        let first = *self
            .bindings
            .iter()
            .find(|b| b.key(self.base) == self.keys[k])
            .expect("every key has a binding");
        let at = first.at(&[Key::Field("graph")]);
        let overrides: Vec<(String, f64)> =
            first.set.iter().map(|(k, v)| (k.clone(), *v)).collect();
        let result = match self.checked {
            Some(c)
                if join_normalised(Path::new(""), &c.path.to_string_lossy()) == path
                    && c.overrides.iter().cloned().collect::<BTreeMap<_, _>>() == *first.set =>
            {
                Ok(c.graph.clone())
            }
            _ => load_graph(&path, &CheckOptions { overrides }),
        };
        // The files the graph imports are watched too (`watch` re-renders when one changes),
        // also those a failed check got to (a broken imported file is where the fix will go).
        let imported: Vec<std::path::PathBuf> = match &result {
            Ok(g) => g.imports().to_vec(),
            Err(LoadError::Invalid(d)) => d
                .list
                .iter()
                .filter_map(|d| d.file.as_ref().map(|f| std::path::PathBuf::from(&f.name)))
                .collect(),
            Err(_) => Vec::new(),
        };
        for f in imported {
            if !self.files.contains(&f) {
                self.files.push(f);
            }
        }
        match result {
            Ok(g) if self.desc.probe_nodes => Some(g.with_node_probes()),
            Ok(g) => Some(g),
            Err(LoadError::Io { source, .. }) => {
                self.problems.add(
                    C::UnknownReference,
                    &at,
                    format!(
                        "material \"{}\": cannot read the graph file {}: {source}",
                        first.material,
                        path.display()
                    ),
                    Some(if first.short {
                        "`height: \"FILE.OUTPUT\"` is split at the last dot; graph paths are relative to the scene file".into()
                    } else {
                        "graph paths are relative to the scene file".into()
                    }),
                );
                None
            }
            Err(LoadError::Invalid(diagnostics)) if self.problems.located.is_none() => {
                // A preview scene built in code: its overrides are the command line's `--set`,
                // which the checker's own messages name.
                self.problems.other.push(diagnostics);
                None
            }
            Err(LoadError::Invalid(diagnostics)) => {
                self.graph_problems(first, &path, diagnostics);
                None
            }
        }
    }

    /// Sorts a graph's problems: an override of a param the graph does not have is the scene's
    /// mistake (at the scene's `set` entry); everything else is about the graph file.
    fn graph_problems(&mut self, first: Binding<'a>, path: &Path, diagnostics: Diagnostics) {
        let (params, rest): (Vec<Diagnostic>, Vec<Diagnostic>) = diagnostics
            .list
            .into_iter()
            .partition(|d| d.class == C::UnknownParam && d.span.is_none());
        for d in params {
            let param = first
                .set
                .keys()
                .find(|k| d.message.contains(&format!("\"{k}\"")))
                .map(String::as_str)
                .unwrap_or("");
            self.problems.add(
                C::UnknownParam,
                &first.at(&[Key::Field("set"), Key::EntryName(param)]),
                format!(
                    "material \"{}\": `{}`: the graph {} has no param \"{param}\"",
                    first.material,
                    first.channel,
                    path.display()
                ),
                d.help.clone(),
            );
        }
        if !rest.is_empty() {
            self.problems.other.push(Diagnostics {
                file: diagnostics.file,
                list: rest,
            });
        }
    }

    /// Chooses each binding's output and collects the outputs each graph is compiled for; a
    /// bump's graph gets its height's gradient as one more output.
    pub(super) fn outputs(&mut self) {
        self.outputs = vec![Vec::new(); self.keys.len()];
        for i in 0..self.bindings.len() {
            let chosen = self.output(self.bindings[i]);
            self.chosen.push(chosen);
        }
        for i in 0..self.bindings.len() {
            if self.bindings[i].is_bump() {
                self.gradient(i);
            }
        }
    }

    /// Adds the gradient of bump binding `i`'s height to its graph (once per height), and binds
    /// the binding to it; a height that cannot be differentiated is a problem.
    fn gradient(&mut self, i: usize) {
        let b = self.bindings[i];
        let Some((k, height, _)) = self.chosen[i].clone() else {
            return;
        };
        let graph = self.graphs[k].as_ref().expect("an output was chosen");
        let name = gradient_output(&height);
        if graph.output(&name).is_none() {
            match graph.with_gradient_output(&height, &name) {
                Ok(with) => self.graphs[k] = Some(with),
                Err(message) => {
                    self.problems.add(
                        C::NotDifferentiable,
                        &output_at(b),
                        format!(
                            "material \"{}\": `bump`: the graph {}: {message}",
                            b.material,
                            self.keys[k].0.display()
                        ),
                        Some("a bump needs the gradient of its height: take a height that does not use Gradient of a noise".into()),
                    );
                    self.chosen[i] = None;
                    return;
                }
            }
        }
        // A zero bump is checked like any other, and then left out: its gradient is not
        // compiled (the graph's other outputs stay as they are, bit for bit, and cost no more).
        if bump_strength(&b) != 0.0 {
            if !self.outputs[k].contains(&name) {
                self.outputs[k].push(name.clone());
            }
            self.chosen[i] = Some((k, name, true));
        } else if self.outputs[k].is_empty() {
            // No output of this graph is evaluated; compile the smallest tape, not all outputs.
            self.outputs[k].push(height);
        }
    }

    /// The output binding `b` reads (named, or its channel's default), or `None` after a
    /// problem.
    fn output(&mut self, b: Binding<'a>) -> Option<Chosen> {
        let key = b.key(self.base);
        let k = self.keys.iter().position(|x| *x == key).expect("key");
        let graph = self.graphs[k].as_ref()?;
        let path = &self.keys[k].0;
        let name = match b.output {
            Some(name) => named_output(&mut self.problems, b, graph, path, name)?,
            None => default_output(&mut self.problems, b, graph, path)?,
        };
        let ty = graph
            .output(&name)
            .map_or(Type::Scalar, |o| output_type(graph, o));
        if b.scalar && ty == Type::Vec3 {
            let message = if b.is_bump() {
                format!(
                    "material \"{}\": `bump`: a height is a number, and output \"{name}\" is a vec3",
                    b.material
                )
            } else {
                format!(
                    "material \"{}\": `{}` is a number, and output \"{name}\" is a colour",
                    b.material, b.channel
                )
            };
            self.problems.add(
                C::Type,
                &output_at(b),
                message,
                Some("bind a scalar output".into()),
            );
            return None;
        }
        if b.is_bump() {
            // Its gradient is compiled, not the height itself.
            return Some((k, name, false));
        }
        if !self.outputs[k].contains(&name) {
            self.outputs[k].push(name.clone());
        }
        Some((k, name, ty == Type::Vec3))
    }

    /// Compiles each graph for exactly the outputs bound to it, and for the box it is evaluated
    /// over (`extents`: precision chosen per instruction, as a bake's region chooses it).
    pub(super) fn compile_textures(
        &mut self,
        extents: &[Option<Extent>],
    ) -> Result<Vec<CompiledTexture>, RenderError> {
        let graphs = std::mem::take(&mut self.graphs);
        let outputs = std::mem::take(&mut self.outputs);
        let mut textures = Vec::with_capacity(self.keys.len());
        let cases = self.keys.iter().zip(graphs).zip(outputs).zip(extents);
        for (((key, graph), outputs), extent) in cases {
            let graph = graph.expect("checked above");
            let tape = compile(
                &graph,
                &CompileOptions {
                    outputs: outputs.clone(),
                    spacing: None,
                    extent: *extent,
                    ..Default::default()
                },
            )
            .map_err(|d| RenderError::Invalid(vec![d]))?;
            textures.push(CompiledTexture {
                graph: key.0.clone(),
                overrides: key
                    .1
                    .iter()
                    .map(|(k, v)| (k.clone(), f64::from_bits(*v)))
                    .collect(),
                outputs,
                tape,
            });
        }
        Ok(textures)
    }

    /// Builds the used materials, in order of first use, and the evaluation groups they read.
    pub(super) fn materials(
        &self,
        textures: &[CompiledTexture],
    ) -> (Vec<Material>, Vec<EvalGroup>) {
        let mut groups = Groups::default();
        let materials = self
            .used
            .iter()
            .map(|name| self.material(name, textures, &mut groups))
            .collect();
        (materials, groups.list)
    }

    /// Builds material `name`: its constants, its textures (each in its evaluation group), and
    /// the ambient channel from the diffuse one when it has none.
    fn material(&self, name: &str, textures: &[CompiledTexture], groups: &mut Groups) -> Material {
        let mut material = Material {
            ambient: Channel::Constant(Vec3::ZERO),
            diffuse: Channel::Constant(Vec3::ZERO),
            specular: Channel::Constant(Vec3::ZERO),
            shininess: Channel::Constant(Vec3::ZERO),
            bump: None,
            groups: Vec::new(),
        };
        let mut has_ambient = false;
        for (c, value) in self
            .constants
            .iter()
            .filter(|c| c.0 == name)
            .map(|c| (c.1, c.2))
        {
            *channel_mut(&mut material, c) = Channel::Constant(value);
            has_ambient |= c == "ambient";
        }
        for (b, chosen) in self
            .bindings
            .iter()
            .zip(&self.chosen)
            .filter(|(b, _)| b.material == name && !(b.is_bump() && bump_strength(b) == 0.0))
        {
            let (k, output, vec3) = chosen.as_ref().expect("checked above");
            let transform = transform_of(b.transform).expect("checked above");
            let g = groups.index(*k, b.space, transform);
            let slot = match material.groups.iter().position(|x| *x == g) {
                Some(s) => s,
                None => {
                    material.groups.push(g);
                    material.groups.len() - 1
                }
            };
            let tape = &textures[*k].tape;
            let channel = tape.output(output).expect("compiled").first_channel;
            if b.is_bump() {
                material.bump = Some(Bump {
                    slot,
                    channel,
                    strength: bump_strength(b),
                });
                continue;
            }
            *channel_mut(&mut material, b.channel) = Channel::Texture {
                slot,
                channel,
                vec3: *vec3,
                multiply: b.multiply as f32,
            };
            has_ambient |= b.channel == "ambient";
        }
        if !has_ambient {
            material.ambient = material.diffuse;
        }
        material
    }
}

/// The evaluation groups found so far, and the keys that tell them apart.
#[derive(Default)]
struct Groups {
    list: Vec<EvalGroup>,
    keys: Vec<(usize, Space, [u32; 12])>,
}

impl Groups {
    /// The index of the group of (texture, space, transform), added when it is new.
    fn index(&mut self, texture: usize, space: Space, transform: Affine3A) -> usize {
        let bits: [u32; 12] = std::array::from_fn(|i| transform.to_cols_array()[i].to_bits());
        let key = (texture, space, bits);
        match self.keys.iter().position(|x| *x == key) {
            Some(g) => g,
            None => {
                self.keys.push(key);
                self.list.push(EvalGroup {
                    texture,
                    space,
                    transform,
                    gradient_to_space: Mat3::from(transform.matrix3).transpose(),
                });
                self.list.len() - 1
            }
        }
    }
}

/// Where binding `b`'s `output` is in the scene file.
fn output_at(b: Binding) -> Vec<Key> {
    b.at(&[Key::Field("output")])
}

/// The output `name` that binding `b` names, or `None` (and a problem) when `graph` (at `path`)
/// has none of that name.
fn named_output(
    problems: &mut Problems,
    b: Binding,
    graph: &CheckedGraph,
    path: &Path,
    name: &str,
) -> Option<String> {
    if graph.output(name).is_some() {
        return Some(name.to_string());
    }
    let names: Vec<&str> = graph.outputs.iter().map(|o| o.name.as_str()).collect();
    let help = match crate::nodes::suggest_from(name, names.iter().copied()) {
        Some(s) => format!(
            "did you mean \"{s}\"? Its outputs are: {}",
            names.join(", ")
        ),
        None => format!("its outputs are: {}", names.join(", ")),
    };
    problems.add(
        C::UnknownOutput,
        &output_at(b),
        format!(
            "material \"{}\": `{}`: the graph {} has no output \"{name}\"",
            b.material,
            b.channel,
            path.display()
        ),
        Some(help),
    );
    None
}

/// The output of `graph` (at `path`) that binding `b`'s channel reads by default — for a
/// scalar channel the first scalar output; else `colour`, the first vec3 output or the first
/// output — or `None` (and a problem) when it has none.
fn default_output(
    problems: &mut Problems,
    b: Binding,
    graph: &CheckedGraph,
    path: &Path,
) -> Option<String> {
    let pick = if b.scalar {
        graph
            .outputs
            .iter()
            .find(|o| output_type(graph, o) == Type::Scalar)
    } else {
        graph
            .output("colour")
            .filter(|o| output_type(graph, o) == Type::Vec3)
            .or_else(|| {
                graph
                    .outputs
                    .iter()
                    .find(|o| output_type(graph, o) == Type::Vec3)
            })
            .or_else(|| graph.outputs.first())
    };
    if let Some(o) = pick {
        return Some(o.name.clone());
    }
    let names: Vec<&str> = graph.outputs.iter().map(|o| o.name.as_str()).collect();
    problems.add(
        C::UnknownOutput,
        &b.at(&[]),
        format!(
            "material \"{}\": `{}` needs a {} output and the graph {} has none",
            b.material,
            b.channel,
            if b.scalar {
                "scalar"
            } else {
                "colour or scalar"
            },
            path.display()
        ),
        Some(format!("its outputs are: {}", names.join(", "))),
    );
    None
}

/// The name of the output that is the gradient of output `height` (not a name a graph file
/// can give an output).
fn gradient_output(height: &str) -> String {
    format!("∇{height}")
}

/// The factor on a bump's gradient: its `strength` times its height's `multiply`, as shaded.
fn bump_strength(b: &Binding) -> f32 {
    (b.strength * b.multiply) as f32
}

/// The type of `output`'s value.
fn output_type(graph: &CheckedGraph, output: &Output) -> Type {
    graph.nodes[output.node as usize].ty
}

/// The channel of `m` named `name`.
fn channel_mut<'a>(m: &'a mut Material, name: &str) -> &'a mut Channel {
    match name {
        "ambient" => &mut m.ambient,
        "diffuse" => &mut m.diffuse,
        "specular" => &mut m.specular,
        _ => &mut m.shininess,
    }
}
