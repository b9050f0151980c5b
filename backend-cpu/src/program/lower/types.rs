//! naga types as compiled code holds them: a value is a flat list of scalar *leaves*
//! (struct members in order, vectors by component, matrices column by column, arrays by
//! element), each with the byte offset it has in memory (naga's layout: member offsets,
//! array strides, matrix column strides).

use super::{LResult, LowerError};
use cranelift_codegen::ir::Type;
use cranelift_codegen::ir::types::{F32, I8, I32};
use naga::{ArraySize, Scalar, ScalarKind, TypeInner, UniqueArena};

/// The kind of one scalar leaf.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Leaf {
    F32,
    I32,
    U32,
    Bool,
}

impl Leaf {
    /// The Cranelift type a leaf is held in (bools as 0/1 in an `i8`).
    pub fn clif(self) -> Type {
        match self {
            Leaf::F32 => F32,
            Leaf::I32 | Leaf::U32 => I32,
            Leaf::Bool => I8,
        }
    }

    /// The leaf of a naga scalar; f16, f64 and 64-bit integers are outside the front end's
    /// capabilities (`optik_core::frontend::capabilities`), so they never reach here from a
    /// validated module.
    pub fn of(scalar: Scalar) -> LResult<Leaf> {
        match (scalar.kind, scalar.width) {
            (ScalarKind::Float, 4) => Ok(Leaf::F32),
            (ScalarKind::Sint, 4) => Ok(Leaf::I32),
            (ScalarKind::Uint, 4) => Ok(Leaf::U32),
            (ScalarKind::Bool, _) => Ok(Leaf::Bool),
            _ => Err(LowerError::unspanned(format!(
                "scalar type {:?} of {} bytes is not supported by the CPU JIT (f32, i32, u32 and bool are)",
                scalar.kind, scalar.width
            ))),
        }
    }

    /// Whether comparisons and shifts treat it as signed.
    pub fn is_signed(self) -> bool {
        self == Leaf::I32
    }
}

/// The leaves of a type with their byte offsets.
#[derive(Clone, Debug, Default)]
pub(crate) struct Layout {
    pub leaves: Vec<(u32, Leaf)>,
    /// Whether the leaves are atomics (loaded and stored with atomic instructions).
    pub atomic: bool,
}

impl Layout {
    pub fn len(&self) -> usize {
        self.leaves.len()
    }

    /// The Cranelift types of the leaves.
    pub fn clif_types(&self) -> Vec<Type> {
        self.leaves.iter().map(|(_, l)| l.clif()).collect()
    }
}

/// How one level of indexing steps into a composite type.
pub(crate) struct Step {
    /// The element's type.
    pub child: TypeInner,
    /// Leaves per element.
    pub leaf_stride: u32,
    /// Bytes per element.
    pub byte_stride: u32,
    /// Elements; `None` for a runtime-sized array.
    pub count: Option<u32>,
    /// For a struct member access: its leaf and byte offsets (strides do not apply).
    pub member: Option<(u32, u32)>,
}

/// Types of one module, for layouts and indexing.
#[derive(Clone, Copy)]
pub(crate) struct Types<'a> {
    pub arena: &'a UniqueArena<naga::Type>,
}

impl<'a> Types<'a> {
    /// Leaves of a fixed-size type.
    pub fn layout(&self, inner: &TypeInner) -> LResult<Layout> {
        let mut layout = Layout::default();
        self.push_leaves(inner, 0, &mut layout)?;
        Ok(layout)
    }

    /// Number of leaves of a fixed-size type.
    pub fn leaf_count(&self, inner: &TypeInner) -> LResult<u32> {
        Ok(match *inner {
            TypeInner::Scalar(_) | TypeInner::Atomic(_) => 1,
            TypeInner::Vector { size, .. } => size as u32,
            TypeInner::Matrix { columns, rows, .. } => columns as u32 * rows as u32,
            TypeInner::Array {
                base,
                size: ArraySize::Constant(n),
                ..
            } => n.get() * self.leaf_count(&self.arena[base].inner)?,
            TypeInner::Struct { ref members, .. } => {
                let mut n = 0;
                for m in members {
                    n += self.leaf_count(&self.arena[m.ty].inner)?;
                }
                n
            }
            ref other => return Err(unsupported_type(other)),
        })
    }

    /// Whether holding a value of this type in registers is sensible: no arrays (which are
    /// indexed through memory) anywhere inside.
    pub fn is_register_type(&self, inner: &TypeInner) -> bool {
        match *inner {
            TypeInner::Scalar(_) | TypeInner::Vector { .. } | TypeInner::Matrix { .. } => true,
            TypeInner::Struct { ref members, .. } => members
                .iter()
                .all(|m| self.is_register_type(&self.arena[m.ty].inner)),
            _ => false,
        }
    }

    /// Byte size of a fixed-size type.
    pub fn size(&self, inner: &TypeInner) -> u32 {
        match *inner {
            TypeInner::Scalar(s) | TypeInner::Atomic(s) => s.width.max(1) as u32,
            TypeInner::Vector { size, scalar } => size as u32 * scalar.width.max(1) as u32,
            TypeInner::Matrix {
                columns,
                rows,
                scalar,
            } => columns as u32 * column_stride(rows, scalar),
            TypeInner::Array {
                stride,
                size: ArraySize::Constant(n),
                ..
            } => stride * n.get(),
            TypeInner::Array { stride, .. } => stride,
            TypeInner::Struct { span, .. } => span,
            _ => 0,
        }
    }

    fn push_leaves(&self, inner: &TypeInner, offset: u32, out: &mut Layout) -> LResult<()> {
        match *inner {
            TypeInner::Scalar(s) => out.leaves.push((offset, Leaf::of(s)?)),
            TypeInner::Atomic(s) => {
                out.atomic = true;
                out.leaves.push((offset, Leaf::of(s)?));
            }
            TypeInner::Vector { size, scalar } => {
                let leaf = Leaf::of(scalar)?;
                for i in 0..size as u32 {
                    out.leaves.push((offset + 4 * i, leaf));
                }
            }
            TypeInner::Matrix {
                columns,
                rows,
                scalar,
            } => {
                let leaf = Leaf::of(scalar)?;
                let stride = column_stride(rows, scalar);
                for c in 0..columns as u32 {
                    for r in 0..rows as u32 {
                        out.leaves.push((offset + c * stride + 4 * r, leaf));
                    }
                }
            }
            TypeInner::Array {
                base,
                size: ArraySize::Constant(n),
                stride,
            } => {
                let base = &self.arena[base].inner;
                for i in 0..n.get() {
                    self.push_leaves(base, offset + i * stride, out)?;
                }
            }
            TypeInner::Struct { ref members, .. } => {
                for m in members {
                    self.push_leaves(&self.arena[m.ty].inner, offset + m.offset, out)?;
                }
            }
            ref other => return Err(unsupported_type(other)),
        }
        Ok(())
    }

    /// Stepping into `inner` by a constant index (`Some`) or a dynamic one (`None`).
    pub fn step(&self, inner: &TypeInner, index: Option<u32>) -> LResult<Step> {
        let step = |child: TypeInner, leaf_stride, byte_stride, count| Step {
            child,
            leaf_stride,
            byte_stride,
            count,
            member: None,
        };
        Ok(match *inner {
            TypeInner::Vector { size, scalar } => {
                step(TypeInner::Scalar(scalar), 1, 4, Some(size as u32))
            }
            TypeInner::Matrix {
                columns,
                rows,
                scalar,
            } => step(
                TypeInner::Vector { size: rows, scalar },
                rows as u32,
                column_stride(rows, scalar),
                Some(columns as u32),
            ),
            TypeInner::Array { base, size, stride } => {
                let child = self.arena[base].inner.clone();
                let leaves = match size {
                    ArraySize::Dynamic => 0,
                    _ => self.leaf_count(&child)?,
                };
                let count = match size {
                    ArraySize::Constant(n) => Some(n.get()),
                    ArraySize::Dynamic => None,
                    ArraySize::Pending(_) => {
                        return Err(LowerError::unspanned(
                            "an array sized by an override is not supported by the CPU JIT",
                        ));
                    }
                };
                step(child, leaves, stride, count)
            }
            TypeInner::Struct { ref members, .. } => {
                let Some(index) = index else {
                    return Err(LowerError::unspanned("a struct indexed by a runtime value"));
                };
                let member = members
                    .get(index as usize)
                    .ok_or_else(|| LowerError::unspanned("struct member index out of range"))?;
                let mut leaf = 0;
                for m in &members[..index as usize] {
                    leaf += self.leaf_count(&self.arena[m.ty].inner)?;
                }
                let mut s = step(
                    self.arena[member.ty].inner.clone(),
                    0,
                    0,
                    Some(members.len() as u32),
                );
                s.member = Some((leaf, member.offset));
                s
            }
            ref other => return Err(unsupported_type(other)),
        })
    }
}

/// Bytes between matrix columns (a column is aligned as a vector of `rows`).
pub(crate) fn column_stride(rows: naga::VectorSize, scalar: Scalar) -> u32 {
    let width = scalar.width as u32;
    match rows {
        naga::VectorSize::Bi => 2 * width,
        _ => 4 * width,
    }
}

fn unsupported_type(inner: &TypeInner) -> LowerError {
    LowerError::unspanned(format!(
        "values of type {inner:?} are not supported by the CPU JIT"
    ))
}
