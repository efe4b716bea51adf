//! Passes on naga's IR that the GPU path and the shader export share: float widths changed
//! ([`Widths`]: the export's module made all-f32, `shader/narrow.rs`; the noise bases' f64
//! twins made from their f32 forms, `widen.rs`) and calls followed or redirected
//! ([`order_by_calls`], [`map_calls`]: `shader/functions.rs`, `widen.rs`). naga has no such
//! passes of its own; they are small because only scalar widths and call targets change.

use naga::{
    Block, Expression, Function, Handle, Literal, Module, Scalar, ScalarKind, Statement, Type,
    TypeInner,
};

/// One float width made another: every type, literal and conversion of `from` becomes `to`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Widths {
    pub from: Scalar,
    pub to: Scalar,
}

/// f64 to f32 (the shader export).
#[cfg(feature = "shader")]
pub(crate) const NARROW: Widths = Widths {
    from: Scalar::F64,
    to: Scalar::F32,
};

/// f32 to f64 (the bases' twins).
pub(crate) const WIDEN: Widths = Widths {
    from: Scalar::F32,
    to: Scalar::F64,
};

impl Widths {
    fn scalar(self, s: Scalar) -> Scalar {
        if s == self.from {
            self.to
        } else {
            s
        }
    }

    /// Per type handle (by index), the handle of its form at the new width: itself where it
    /// holds no `from` scalar; for a struct that does, the type `twin` names (the twins' own
    /// struct, declared in WGSL) or else a type added to the arena (its name kept; struct
    /// members and array strides laid out for the new members by naga's own layouter, as the
    /// WGSL front end lays them out).
    pub(crate) fn types(
        self,
        module: &mut Module,
        twin: impl Fn(&Module, &Type) -> Option<Handle<Type>>,
    ) -> Result<Vec<Handle<Type>>, String> {
        let old: Vec<(Handle<Type>, Type)> =
            module.types.iter().map(|(h, ty)| (h, ty.clone())).collect();
        let mut map: Vec<Handle<Type>> = Vec::with_capacity(old.len());
        let mut layouter = naga::proc::Layouter::default();
        let layout_error = |e: naga::proc::LayoutError| format!("laying out a retyped type: {e}");
        for (handle, ty) in old {
            let base = |b: Handle<Type>| map[b.index()];
            let s = |s: Scalar| self.scalar(s);
            let inner = match ty.inner {
                TypeInner::Scalar(scalar) => TypeInner::Scalar(s(scalar)),
                TypeInner::Atomic(scalar) => TypeInner::Atomic(s(scalar)),
                TypeInner::Vector { size, scalar } => TypeInner::Vector {
                    size,
                    scalar: s(scalar),
                },
                TypeInner::Matrix {
                    columns,
                    rows,
                    scalar,
                } => TypeInner::Matrix {
                    columns,
                    rows,
                    scalar: s(scalar),
                },
                TypeInner::ValuePointer {
                    size,
                    scalar,
                    space,
                } => TypeInner::ValuePointer {
                    size,
                    scalar: s(scalar),
                    space,
                },
                TypeInner::Pointer { base: b, space } => TypeInner::Pointer {
                    base: base(b),
                    space,
                },
                TypeInner::BindingArray { base: b, size } => TypeInner::BindingArray {
                    base: base(b),
                    size,
                },
                TypeInner::Array { base: b, size, .. } if base(b) != b => {
                    layouter.update(module.to_ctx()).map_err(layout_error)?;
                    TypeInner::Array {
                        base: base(b),
                        size,
                        stride: layouter[base(b)].to_stride(),
                    }
                }
                TypeInner::Struct { ref members, .. }
                    if members.iter().any(|m| base(m.ty) != m.ty) =>
                {
                    if let Some(twin) = twin(module, &ty) {
                        map.push(twin);
                        continue;
                    }
                    layouter.update(module.to_ctx()).map_err(layout_error)?;
                    let mut members = members.clone();
                    let (mut offset, mut alignment) = (0, naga::proc::Alignment::ONE);
                    for m in &mut members {
                        m.ty = base(m.ty);
                        let layout = layouter[m.ty];
                        offset = layout.alignment.round_up(offset);
                        m.offset = offset;
                        offset += layout.size;
                        alignment = alignment.max(layout.alignment);
                    }
                    TypeInner::Struct {
                        members,
                        span: alignment.round_up(offset),
                    }
                }
                other => other,
            };
            if inner == module.types[handle].inner {
                map.push(handle);
            } else {
                let span = module.types.get_span(handle);
                map.push(module.types.insert(
                    Type {
                        name: ty.name,
                        inner,
                    },
                    span,
                ));
            }
        }
        Ok(map)
    }

    /// An expression's literal, conversion or type of the old width made the new one. A
    /// narrowed literal out of f32's range becomes infinite here, which the validator refuses
    /// wherever it is still used (the export's f64-only constants are read only by functions
    /// it replaces).
    pub(crate) fn expression(self, e: &mut Expression, t: &impl Fn(Handle<Type>) -> Handle<Type>) {
        match e {
            Expression::Literal(l) => *l = self.literal(*l),
            Expression::As {
                kind: ScalarKind::Float,
                convert: Some(width),
                ..
            } if *width == self.from.width => *width = self.to.width,
            Expression::ZeroValue(ty)
            | Expression::Compose { ty, .. }
            | Expression::AtomicResult { ty, .. }
            | Expression::WorkGroupUniformLoadResult { ty }
            | Expression::SubgroupOperationResult { ty } => *ty = t(*ty),
            _ => {}
        }
    }

    /// `f`'s argument, result and variable types and its expressions at the new width (`t`:
    /// [`Widths::types`]' map).
    pub(crate) fn function(self, f: &mut Function, t: &impl Fn(Handle<Type>) -> Handle<Type>) {
        for a in &mut f.arguments {
            a.ty = t(a.ty);
        }
        if let Some(r) = &mut f.result {
            r.ty = t(r.ty);
        }
        for (_, v) in f.local_variables.iter_mut() {
            v.ty = t(v.ty);
        }
        for (_, e) in f.expressions.iter_mut() {
            self.expression(e, t);
        }
    }

    /// A literal of the old width at the new one ([`widened`] for f32 to f64).
    pub(crate) fn literal(self, l: Literal) -> Literal {
        match (l, self.to) {
            (Literal::F64(v), Scalar::F32) => Literal::F32(v as f32),
            (Literal::F32(v), Scalar::F64) => Literal::F64(widened(v)),
            _ => l,
        }
    }
}

/// An f32 literal's f64 form: the decimal the WGSL most likely wrote, which the f64 twin of a
/// basis must read as f64 (`0.1` is 0.1, not the f32 nearest it, 0.100000001490116). The IR
/// keeps only the f32; its shortest decimal (at most 9 digits) is taken where it has at most 7
/// significant digits (what an author writes for a short decimal), else the f32's exact value
/// (literals written to more digits are the exact value of an f32: a power of two such as
/// 2^-24, f32's largest finite value).
pub(crate) fn widened(v: f32) -> f64 {
    if !v.is_finite() {
        return f64::from(v);
    }
    let short = format!("{v:e}");
    let mantissa = short.split('e').next().unwrap_or("");
    let digits = mantissa.chars().filter(char::is_ascii_digit).count();
    match short.parse::<f64>() {
        Ok(decimal) if digits <= 7 => decimal,
        _ => f64::from(v),
    }
}

/// A function's signature: its argument types and its result type (two functions with equal
/// signatures can take each other's calls).
pub(crate) fn signature(f: &Function) -> (Vec<Handle<Type>>, Option<Handle<Type>>) {
    let arguments = f.arguments.iter().map(|a| a.ty).collect();
    (arguments, f.result.as_ref().map(|r| r.ty))
}

/// Reorders `module.functions` so that every function comes after the functions it calls
/// (depth first, in the old order otherwise; naga's validator and writers need it), and points
/// every call at the new handles.
pub(crate) fn order_by_calls(module: &mut Module) {
    let n = module.functions.len();
    let callees: Vec<Vec<usize>> = module
        .functions
        .iter()
        .map(|(_, f)| {
            let mut calls = Vec::new();
            each_call(&f.body, &mut |h| calls.push(h.index()));
            calls
        })
        .collect();
    let (mut order, mut state) = (Vec::with_capacity(n), vec![0u8; n]);
    for root in 0..n {
        if state[root] != 0 {
            continue;
        }
        // Iterative depth-first post-order: (function, index of its next callee). WGSL has
        // no recursion, so there are no cycles.
        state[root] = 1;
        let mut stack = vec![(root, 0usize)];
        while let Some(top) = stack.last_mut() {
            let (f, next) = *top;
            if let Some(&callee) = callees[f].get(next) {
                top.1 += 1;
                if state[callee] == 0 {
                    state[callee] = 1;
                    stack.push((callee, 0));
                }
            } else {
                order.push(f);
                stack.pop();
            }
        }
    }
    let old: Vec<_> = module.functions.drain().map(|(_, f, s)| (f, s)).collect();
    let mut old: Vec<Option<(Function, naga::Span)>> = old.into_iter().map(Some).collect();
    let mut new_handle = vec![None; n];
    for i in order {
        let (f, span) = old[i].take().expect("each function once");
        new_handle[i] = Some(module.functions.append(f, span));
    }
    map_calls(module, |h| {
        new_handle[h.index()].expect("every function placed")
    });
}

/// Points every call in `module` (its functions' and entry points') at `map(callee)`.
pub(crate) fn map_calls(module: &mut Module, map: impl Fn(Handle<Function>) -> Handle<Function>) {
    let entries = module.entry_points.iter_mut().map(|e| &mut e.function);
    for f in module.functions.iter_mut().map(|(_, f)| f).chain(entries) {
        map_function_calls(f, &map);
    }
}

/// Points every call in `f` at `map(callee)`.
pub(crate) fn map_function_calls(
    f: &mut Function,
    map: &impl Fn(Handle<Function>) -> Handle<Function>,
) {
    for (_, e) in f.expressions.iter_mut() {
        if let Expression::CallResult(h) = e {
            *h = map(*h);
        }
    }
    each_call_mut(&mut f.body, &mut |h| *h = map(*h));
}

/// Calls `each` with the function of every call in `block`, nested blocks included.
pub(crate) fn each_call(block: &Block, each: &mut impl FnMut(Handle<Function>)) {
    for s in block.iter() {
        match s {
            Statement::Call { function, .. } => each(*function),
            Statement::Block(b) => each_call(b, each),
            Statement::If { accept, reject, .. } => {
                each_call(accept, each);
                each_call(reject, each);
            }
            Statement::Switch { cases, .. } => cases.iter().for_each(|c| each_call(&c.body, each)),
            Statement::Loop {
                body, continuing, ..
            } => {
                each_call(body, each);
                each_call(continuing, each);
            }
            _ => {}
        }
    }
}

/// [`each_call`], able to change the function called.
fn each_call_mut(block: &mut Block, each: &mut impl FnMut(&mut Handle<Function>)) {
    for s in block.iter_mut() {
        match s {
            Statement::Call { function, .. } => each(function),
            Statement::Block(b) => each_call_mut(b, each),
            Statement::If { accept, reject, .. } => {
                each_call_mut(accept, each);
                each_call_mut(reject, each);
            }
            Statement::Switch { cases, .. } => cases
                .iter_mut()
                .for_each(|c| each_call_mut(&mut c.body, each)),
            Statement::Loop {
                body, continuing, ..
            } => {
                each_call_mut(body, each);
                each_call_mut(continuing, each);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_widened_literal_is_the_decimal_written_or_the_f32_exactly() {
        assert_eq!(widened(0.1), 0.1);
        assert_eq!(widened(1e-6), 1e-6);
        assert_eq!(widened(76.0), 76.0);
        assert_eq!(widened(0.5), 0.5);
        assert_eq!(widened(-0.0).to_bits(), (-0.0f64).to_bits());
        // Written to more digits than an f32 holds: the exact f32.
        assert_eq!(widened(5.960_464_5e-8), 2f64.powi(-24));
        assert_eq!(widened(f32::MAX), 3.4028234663852886e38);
        assert_eq!(widened(f32::INFINITY), f64::INFINITY);
        // An f32 of eight significant digits is its own exact value.
        assert_eq!(widened(0.123_456_78), f64::from(0.123_456_78f32));
    }
}
