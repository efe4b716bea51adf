//! References between nodes: the dependency order (iterative depth-first search, cycles
//! reported with the loop) and resolving a name to a node, param or component.

use super::*;

impl Checker {
    /// Orders named nodes so each comes after the nodes it refers to; reports cycles.
    pub(super) fn dependency_order(&mut self, entries: &[(Spanned<Text>, &Value)]) -> Vec<usize> {
        // References of entry i: refs[starts[i]..starts[i + 1]] (flat, one allocation).
        let mut refs: Vec<usize> = Vec::with_capacity(entries.len() * 2);
        let mut starts: Vec<usize> = Vec::with_capacity(entries.len() + 1);
        let mut walk = Vec::new();
        for (_, value) in entries {
            let first = refs.len();
            starts.push(first);
            collect_references(value, &mut walk, &mut |name| {
                let base = name.split('.').next().unwrap_or(name);
                // A name that is both a param and a node is already an error: no edge for it,
                // so `"crack": Mul("crack", 2)` (meaning the param) is not also a cycle.
                let ambiguous = self.params.iter().any(|(p, _)| p == base);
                if let Some(&j) = self.node_index.get(base).filter(|_| !ambiguous) {
                    if !refs[first..].contains(&j) {
                        refs.push(j);
                    }
                }
            });
        }
        starts.push(refs.len());
        let deps = |v: usize| &refs[starts[v]..starts[v + 1]];
        const WHITE: u8 = 0;
        const GREY: u8 = 1;
        const BLACK: u8 = 2;
        let mut state = vec![WHITE; entries.len()];
        let mut in_cycle = vec![false; entries.len()];
        let mut order = Vec::with_capacity(entries.len());
        for root in 0..entries.len() {
            if state[root] != WHITE {
                continue;
            }
            state[root] = GREY;
            let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
            while let Some(&mut (v, ref mut next)) = stack.last_mut() {
                if let Some(&w) = deps(v).get(*next) {
                    *next += 1;
                    match state[w] {
                        WHITE => {
                            state[w] = GREY;
                            stack.push((w, 0));
                        }
                        GREY => {
                            let start = stack.iter().position(|&(u, _)| u == w).unwrap_or(0);
                            let cycle: Vec<usize> =
                                stack[start..].iter().map(|&(u, _)| u).collect();
                            if cycle.iter().all(|&u| !in_cycle[u]) {
                                let mut names: Vec<String> = cycle
                                    .iter()
                                    .map(|&u| format!("\"{}\"", entries[u].0.value))
                                    .collect();
                                names.push(format!("\"{}\"", entries[w].0.value));
                                let (id, value) = &entries[w];
                                self.error(
                                    Diagnostic::new(
                                        Class::Cycle,
                                        format!("the graph has a cycle: {}", names.join(" -> ")),
                                    )
                                    .in_node(id.value.as_str())
                                    .at(value.span)
                                    .label("depends on itself through this expression")
                                    .help("a node cannot use its own value; break the loop"),
                                );
                            }
                            for u in cycle {
                                in_cycle[u] = true;
                            }
                        }
                        _ => {}
                    }
                } else {
                    state[v] = BLACK;
                    if !in_cycle[v] {
                        order.push(v);
                    }
                    stack.pop();
                }
            }
        }
        order
    }

    pub(super) fn reference(&mut self, text: &str, span: Span, origin: &Origin) -> Option<NodeId> {
        let here = Origin {
            node: origin.node.clone(),
            span,
        };
        // A name that failed its own check (an id with a `.`, a bad param) resolves silently.
        if self.poisoned.iter().any(|p| p == text)
            || self
                .node_index
                .get(text)
                .is_some_and(|_| text.contains('.'))
        {
            return None;
        }
        let (base, component) = match text.split_once('.') {
            Some((b, c)) => (b, Some(c)),
            None => (text, None),
        };
        if self.poisoned.iter().any(|p| p == base) {
            return None;
        }
        let target = if let Some((_, v)) = self.params.iter().find(|(p, _)| p == base) {
            let v = *v;
            Some(self.builder.add(Op::ConstScalar(v), Args::new(), &here))
        } else if let Some(&i) = self.node_index.get(base) {
            // Lowered already (dependency order) or failed with its own diagnostic.
            self.lowered.get(i).copied().flatten()
        } else {
            let candidates: Vec<&str> = self
                .node_index
                .keys()
                .map(|s| s.as_str())
                .chain(self.params.iter().map(|(p, _)| p.as_str()))
                .collect();
            let mut d = Diagnostic::new(
                Class::UnknownReference,
                format!("unknown reference \"{base}\""),
            )
            .in_node(&*origin.node)
            .at(span)
            .label("no node or param has this name");
            if nodes::lookup(base).is_some() {
                d = d.help(format!("`{base}` is a node kind: write it without quotes"));
            } else if let Some(s) = nodes::suggest_from(base, candidates.iter().copied()) {
                d = d.help(format!("did you mean \"{s}\"?"));
            }
            self.error(d);
            return None;
        };
        let target = target?;
        let Some(component) = component else {
            return Some(target);
        };
        let axis = match component {
            "x" | "r" => 0,
            "y" | "g" => 1,
            "z" | "b" => 2,
            _ => {
                self.error(
                    Diagnostic::new(
                        Class::WrongComponent,
                        format!("\"{text}\": there is no component `{component}`"),
                    )
                    .in_node(&*origin.node)
                    .at(span)
                    .label("unknown component")
                    .help("components are .x .y .z (or .r .g .b)"),
                );
                return None;
            }
        };
        if self.builder.ty(target) != Type::Vec3 {
            self.error(
                Diagnostic::new(
                    Class::WrongComponent,
                    format!("\"{text}\": \"{base}\" is a scalar and has no components"),
                )
                .in_node(&*origin.node)
                .at(span)
                .label("scalar")
                .help(format!("use \"{base}\" itself")),
            );
            return None;
        }
        Some(
            self.builder
                .add(Op::Component(axis), smallvec![target], &here),
        )
    }
}
