//! WGSL's numeric built-ins (naga `MathFunction`).
//!
//! Choices where WGSL leaves room, each matched by the hand-written Rust in the tests:
//! - `min(a, b)` is `a < b ? a : b` and `max(a, b)` is `a > b ? a : b` (one `minss`/`maxss`
//!   on x86, and what Rust's compare-and-pick gives); `clamp(e, lo, hi)` is
//!   `min(max(e, lo), hi)`, as the WGSL spec defines it.
//! - Sums (`dot`, matrix products, `length`) add left to right; no contraction into FMA.
//! - `normalize(v)` is `v / length(v)`; `inverseSqrt(x)` is `1 / sqrt(x)`; `mix(a, b, t)`
//!   is `a * (1 - t) + b * t`; `sign(NaN)` is 0.
//! - Transcendentals, `ldexp`, `frexp`, `quantizeToF16` and the data packing functions
//!   (except `pack4x8unorm`, inline for colour output) call Rust (`host.rs`, `math_ref.rs`).

use super::expr::leaf_of;
use super::types::Leaf;
use super::{LResult, LowerError, Lowerer};
use crate::program::host::HostFn;
use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::types::{F32, I32};
use cranelift_codegen::ir::{InstBuilder, MemFlagsData, Value};
use naga::{Expression, Handle, MathFunction as M, TypeInner};

/// Leaf `i` of `v`, broadcasting a scalar.
fn at(v: &[Value], i: usize) -> Value {
    if v.len() == 1 { v[0] } else { v[i] }
}

impl Lowerer<'_, '_> {
    pub(super) fn math(
        &mut self,
        fun: M,
        arg: Handle<Expression>,
        arg1: Option<Handle<Expression>>,
        arg2: Option<Handle<Expression>>,
        arg3: Option<Handle<Expression>>,
    ) -> LResult<Vec<Value>> {
        let ty = self.type_of(arg).clone();
        let leaf = leaf_of(&ty)?;
        let a = self.values(arg)?;
        let b = match arg1 {
            Some(h) => self.values(h)?,
            None => Vec::new(),
        };
        let c = match arg2 {
            Some(h) => self.values(h)?,
            None => Vec::new(),
        };
        let _ = arg3;
        let n = a.len();
        let f32c = |s: &mut Self, x: f32| s.b.ins().f32const(x);
        Ok(match fun {
            M::Abs => a
                .iter()
                .map(|&x| match leaf {
                    Leaf::F32 => self.b.ins().fabs(x),
                    Leaf::I32 => self.b.ins().iabs(x),
                    _ => x,
                })
                .collect(),
            M::Min => (0..n).map(|i| self.min(leaf, a[i], at(&b, i))).collect(),
            M::Max => (0..n).map(|i| self.max(leaf, a[i], at(&b, i))).collect(),
            M::Clamp => (0..n)
                .map(|i| {
                    let lo = self.max(leaf, a[i], at(&b, i));
                    self.min(leaf, lo, at(&c, i))
                })
                .collect(),
            M::Saturate => a
                .iter()
                .map(|&x| {
                    let (zero, one) = (f32c(self, 0.0), f32c(self, 1.0));
                    let lo = self.max(leaf, x, zero);
                    self.min(leaf, lo, one)
                })
                .collect(),
            M::Cos => self.host_map(HostFn::cos, &a),
            M::Cosh => self.host_map(HostFn::cosh, &a),
            M::Sin => self.host_map(HostFn::sin, &a),
            M::Sinh => self.host_map(HostFn::sinh, &a),
            M::Tan => self.host_map(HostFn::tan, &a),
            M::Tanh => self.host_map(HostFn::tanh, &a),
            M::Acos => self.host_map(HostFn::acos, &a),
            M::Asin => self.host_map(HostFn::asin, &a),
            M::Atan => self.host_map(HostFn::atan, &a),
            M::Asinh => self.host_map(HostFn::asinh, &a),
            M::Acosh => self.host_map(HostFn::acosh, &a),
            M::Atanh => self.host_map(HostFn::atanh, &a),
            M::Exp => self.host_map(HostFn::exp, &a),
            M::Exp2 => self.host_map(HostFn::exp2, &a),
            M::Log => self.host_map(HostFn::ln, &a),
            M::Log2 => self.host_map(HostFn::log2, &a),
            M::QuantizeToF16 => self.host_map(HostFn::quantize_f16, &a),
            M::Atan2 => (0..n)
                .map(|i| self.call_host(HostFn::atan2, &[a[i], b[i]])[0])
                .collect(),
            M::Pow => (0..n)
                .map(|i| self.call_host(HostFn::pow, &[a[i], b[i]])[0])
                .collect(),
            M::Ldexp => (0..n)
                .map(|i| self.call_host(HostFn::ldexp, &[a[i], at(&b, i)])[0])
                .collect(),
            M::Radians => {
                let k = f32c(self, 0.017_453_292_f32);
                a.iter().map(|&x| self.b.ins().fmul(x, k)).collect()
            }
            M::Degrees => {
                let k = f32c(self, 57.295_78_f32);
                a.iter().map(|&x| self.b.ins().fmul(x, k)).collect()
            }
            M::Ceil => a.iter().map(|&x| self.b.ins().ceil(x)).collect(),
            M::Floor => a.iter().map(|&x| self.b.ins().floor(x)).collect(),
            M::Trunc => a.iter().map(|&x| self.b.ins().trunc(x)).collect(),
            // Ties to even.
            M::Round => a.iter().map(|&x| self.b.ins().nearest(x)).collect(),
            M::Fract => a
                .iter()
                .map(|&x| {
                    let f = self.b.ins().floor(x);
                    self.b.ins().fsub(x, f)
                })
                .collect(),
            M::Modf => {
                let whole: Vec<Value> = a.iter().map(|&x| self.b.ins().trunc(x)).collect();
                let mut out: Vec<Value> =
                    (0..n).map(|i| self.b.ins().fsub(a[i], whole[i])).collect();
                out.extend(whole);
                out
            }
            M::Frexp => {
                let mut fract = Vec::new();
                let mut exp = Vec::new();
                for &x in &a {
                    let out = self.scratch_addr();
                    fract.push(self.call_host(HostFn::frexp, &[x, out])[0]);
                    exp.push(self.b.ins().load(I32, MemFlagsData::trusted(), out, 0));
                }
                fract.extend(exp);
                fract
            }
            M::Sqrt => a.iter().map(|&x| self.b.ins().sqrt(x)).collect(),
            M::InverseSqrt => a
                .iter()
                .map(|&x| {
                    let s = self.b.ins().sqrt(x);
                    let one = f32c(self, 1.0);
                    self.b.ins().fdiv(one, s)
                })
                .collect(),
            M::Fma => (0..n).map(|i| self.b.ins().fma(a[i], b[i], c[i])).collect(),
            M::Dot => vec![self.dot(&a, &b, leaf)],
            M::Cross => {
                let m = |s: &mut Self, i: usize, j: usize| {
                    let p = s.b.ins().fmul(a[i], b[j]);
                    let q = s.b.ins().fmul(a[j], b[i]);
                    s.b.ins().fsub(p, q)
                };
                vec![m(self, 1, 2), m(self, 2, 0), m(self, 0, 1)]
            }
            M::Length => vec![self.length(&a)],
            M::Distance => {
                let d: Vec<Value> = (0..n).map(|i| self.b.ins().fsub(a[i], b[i])).collect();
                vec![self.length(&d)]
            }
            M::Normalize => {
                let len = self.length(&a);
                a.iter().map(|&x| self.b.ins().fdiv(x, len)).collect()
            }
            M::FaceForward => {
                let d = self.dot(&b, &c, Leaf::F32);
                let zero = f32c(self, 0.0);
                let back = self.b.ins().fcmp(FloatCC::LessThan, d, zero);
                a.iter()
                    .map(|&x| {
                        let neg = self.b.ins().fneg(x);
                        self.b.ins().select(back, x, neg)
                    })
                    .collect()
            }
            M::Reflect => {
                // e1 - 2 * dot(e2, e1) * e2
                let d = self.dot(&b, &a, Leaf::F32);
                let two = f32c(self, 2.0);
                let k = self.b.ins().fmul(two, d);
                (0..n)
                    .map(|i| {
                        let p = self.b.ins().fmul(k, b[i]);
                        self.b.ins().fsub(a[i], p)
                    })
                    .collect()
            }
            M::Refract => self.refract(&a, &b, c[0]),
            M::Sign => a.iter().map(|&x| self.sign(leaf, x)).collect(),
            M::Mix => (0..n)
                .map(|i| {
                    let one = f32c(self, 1.0);
                    let t = at(&c, i);
                    let u = self.b.ins().fsub(one, t);
                    let p = self.b.ins().fmul(a[i], u);
                    let q = self.b.ins().fmul(b[i], t);
                    self.b.ins().fadd(p, q)
                })
                .collect(),
            M::Step => (0..n)
                .map(|i| {
                    let ge = self.b.ins().fcmp(FloatCC::LessThanOrEqual, at(&a, i), b[i]);
                    let (one, zero) = (f32c(self, 1.0), f32c(self, 0.0));
                    self.b.ins().select(ge, one, zero)
                })
                .collect(),
            M::SmoothStep => {
                let m = a.len().max(b.len()).max(c.len());
                (0..m)
                    .map(|i| {
                        // t = clamp((x - lo) / (hi - lo), 0, 1); t * t * (3 - 2 * t)
                        let (lo, hi, x) = (at(&a, i), at(&b, i), at(&c, i));
                        let num = self.b.ins().fsub(x, lo);
                        let den = self.b.ins().fsub(hi, lo);
                        let q = self.b.ins().fdiv(num, den);
                        let (zero, one) = (f32c(self, 0.0), f32c(self, 1.0));
                        let t = self.max(Leaf::F32, q, zero);
                        let t = self.min(Leaf::F32, t, one);
                        let (two, three) = (f32c(self, 2.0), f32c(self, 3.0));
                        let tt = self.b.ins().fmul(t, t);
                        let two_t = self.b.ins().fmul(two, t);
                        let k = self.b.ins().fsub(three, two_t);
                        self.b.ins().fmul(tt, k)
                    })
                    .collect()
            }
            M::Transpose => {
                let TypeInner::Matrix { columns, rows, .. } = ty else {
                    return Err(LowerError::unspanned("transpose of a non-matrix"));
                };
                let (cols, rows) = (columns as usize, rows as usize);
                (0..rows)
                    .flat_map(|r| (0..cols).map(move |c| c * rows + r))
                    .map(|i| a[i])
                    .collect()
            }
            M::Determinant => {
                let TypeInner::Matrix { columns, .. } = ty else {
                    return Err(LowerError::unspanned("determinant of a non-matrix"));
                };
                let size = columns as usize;
                let m: Vec<Vec<Value>> =
                    (0..size).map(|c| a[c * size..][..size].to_vec()).collect();
                vec![self.determinant(&m)]
            }
            M::CountTrailingZeros => a.iter().map(|&x| self.b.ins().ctz(x)).collect(),
            M::CountLeadingZeros => a.iter().map(|&x| self.b.ins().clz(x)).collect(),
            M::CountOneBits => a.iter().map(|&x| self.b.ins().popcnt(x)).collect(),
            M::ReverseBits => a.iter().map(|&x| self.b.ins().bitrev(x)).collect(),
            M::FirstTrailingBit => a
                .iter()
                .map(|&x| {
                    let tz = self.b.ins().ctz(x);
                    let none = self.b.ins().iconst(I32, u32::MAX as i64);
                    let zero = self.b.ins().icmp_imm_u(IntCC::Equal, x, 0);
                    self.b.ins().select(zero, none, tz)
                })
                .collect(),
            M::FirstLeadingBit => a.iter().map(|&x| self.first_leading_bit(leaf, x)).collect(),
            M::ExtractBits => (0..n)
                .map(|i| self.extract_bits(leaf, a[i], b[0], c[0]))
                .collect(),
            M::InsertBits => {
                let d = self.values(
                    arg3.ok_or_else(|| LowerError::unspanned("insertBits needs 4 arguments"))?,
                )?;
                (0..n)
                    .map(|i| self.insert_bits(a[i], b[i], c[0], d[0]))
                    .collect()
            }
            M::Pack4x8unorm => vec![self.pack4x8unorm(&a)],
            M::Pack4x8snorm => self.call_host(HostFn::pack4x8snorm, &a),
            M::Pack2x16snorm => self.call_host(HostFn::pack2x16snorm, &a),
            M::Pack2x16unorm => self.call_host(HostFn::pack2x16unorm, &a),
            M::Pack2x16float => self.call_host(HostFn::pack2x16float, &a),
            M::Pack4xI8 => self.call_host(HostFn::pack4xi8, &a),
            M::Pack4xU8 => self.call_host(HostFn::pack4xu8, &a),
            M::Pack4xI8Clamp => self.call_host(HostFn::pack4xi8_clamp, &a),
            M::Pack4xU8Clamp => self.call_host(HostFn::pack4xu8_clamp, &a),
            M::Unpack4x8snorm => self.unpack(HostFn::unpack4x8snorm, a[0], F32, 4),
            M::Unpack4x8unorm => self.unpack(HostFn::unpack4x8unorm, a[0], F32, 4),
            M::Unpack2x16snorm => self.unpack(HostFn::unpack2x16snorm, a[0], F32, 2),
            M::Unpack2x16unorm => self.unpack(HostFn::unpack2x16unorm, a[0], F32, 2),
            M::Unpack2x16float => self.unpack(HostFn::unpack2x16float, a[0], F32, 2),
            M::Unpack4xI8 => self.unpack(HostFn::unpack4xi8, a[0], I32, 4),
            M::Unpack4xU8 => self.unpack(HostFn::unpack4xu8, a[0], I32, 4),
            M::Dot4I8Packed => self.call_host(HostFn::dot4i8packed, &[a[0], b[0]]),
            M::Dot4U8Packed => self.call_host(HostFn::dot4u8packed, &[a[0], b[0]]),
            M::Outer | M::Inverse => {
                return Err(LowerError::unspanned(format!(
                    "the CPU JIT does not implement {fun:?}"
                )));
            }
        })
    }

    /// `a < b ? a : b` (integers: the usual minimum).
    pub(super) fn min(&mut self, leaf: Leaf, x: Value, y: Value) -> Value {
        match leaf {
            Leaf::F32 => {
                let lt = self.b.ins().fcmp(FloatCC::LessThan, x, y);
                self.b.ins().select(lt, x, y)
            }
            Leaf::I32 => self.b.ins().smin(x, y),
            _ => self.b.ins().umin(x, y),
        }
    }

    /// `a > b ? a : b` (integers: the usual maximum).
    pub(super) fn max(&mut self, leaf: Leaf, x: Value, y: Value) -> Value {
        match leaf {
            Leaf::F32 => {
                let gt = self.b.ins().fcmp(FloatCC::GreaterThan, x, y);
                self.b.ins().select(gt, x, y)
            }
            Leaf::I32 => self.b.ins().smax(x, y),
            _ => self.b.ins().umax(x, y),
        }
    }

    fn host_map(&mut self, f: HostFn, a: &[Value]) -> Vec<Value> {
        a.iter().map(|&x| self.call_host(f, &[x])[0]).collect()
    }

    fn length(&mut self, v: &[Value]) -> Value {
        if v.len() == 1 {
            return self.b.ins().fabs(v[0]);
        }
        let d = self.dot(v, v, Leaf::F32);
        self.b.ins().sqrt(d)
    }

    /// `refract(e1, e2, eta)`: `k = 1 - eta² (1 - dot(e2, e1)²)`; zero if `k < 0`, else
    /// `eta e1 - (eta dot(e2, e1) + sqrt(k)) e2`.
    fn refract(&mut self, e1: &[Value], e2: &[Value], eta: Value) -> Vec<Value> {
        let d = self.dot(e2, e1, Leaf::F32);
        let one = self.b.ins().f32const(1.0);
        let dd = self.b.ins().fmul(d, d);
        let s = self.b.ins().fsub(one, dd);
        let ee = self.b.ins().fmul(eta, eta);
        let t = self.b.ins().fmul(ee, s);
        let k = self.b.ins().fsub(one, t);
        let zero = self.b.ins().f32const(0.0);
        let total = self.b.ins().fcmp(FloatCC::LessThan, k, zero);
        let root = self.b.ins().sqrt(k);
        let ed = self.b.ins().fmul(eta, d);
        let w = self.b.ins().fadd(ed, root);
        (0..e1.len())
            .map(|i| {
                let p = self.b.ins().fmul(eta, e1[i]);
                let q = self.b.ins().fmul(w, e2[i]);
                let r = self.b.ins().fsub(p, q);
                self.b.ins().select(total, zero, r)
            })
            .collect()
    }

    fn sign(&mut self, leaf: Leaf, x: Value) -> Value {
        match leaf {
            Leaf::F32 => {
                let zero = self.b.ins().f32const(0.0);
                let one = self.b.ins().f32const(1.0);
                let minus = self.b.ins().f32const(-1.0);
                let pos = self.b.ins().fcmp(FloatCC::GreaterThan, x, zero);
                let neg = self.b.ins().fcmp(FloatCC::LessThan, x, zero);
                let m = self.b.ins().select(neg, minus, zero);
                self.b.ins().select(pos, one, m)
            }
            _ => {
                let zero = self.b.ins().iconst(I32, 0);
                let one = self.b.ins().iconst(I32, 1);
                let minus = self.b.ins().iconst(I32, u32::MAX as i64);
                let pos = self.b.ins().icmp_imm_u(IntCC::SignedGreaterThan, x, 0);
                let neg = self.b.ins().icmp_imm_u(IntCC::SignedLessThan, x, 0);
                let m = self.b.ins().select(neg, minus, zero);
                self.b.ins().select(pos, one, m)
            }
        }
    }

    /// Laplace expansion along the first row (column-major `m[column][row]`).
    fn determinant(&mut self, m: &[Vec<Value>]) -> Value {
        let n = m.len();
        if n == 2 {
            let p = self.b.ins().fmul(m[0][0], m[1][1]);
            let q = self.b.ins().fmul(m[1][0], m[0][1]);
            return self.b.ins().fsub(p, q);
        }
        let mut acc: Option<Value> = None;
        for c in 0..n {
            let minor: Vec<Vec<Value>> = (0..n)
                .filter(|&k| k != c)
                .map(|k| m[k][1..].to_vec())
                .collect();
            let d = self.determinant(&minor);
            let term = self.b.ins().fmul(m[c][0], d);
            acc = Some(match acc {
                None => term,
                Some(a) if c % 2 == 1 => self.b.ins().fsub(a, term),
                Some(a) => self.b.ins().fadd(a, term),
            });
        }
        acc.expect("matrices have at least two columns")
    }

    /// `firstLeadingBit`: for u32 the highest set bit; for i32 the highest bit that differs
    /// from the sign; -1 (all ones) when there is none.
    fn first_leading_bit(&mut self, leaf: Leaf, x: Value) -> Value {
        let v = if leaf == Leaf::I32 {
            let neg = self.b.ins().icmp_imm_u(IntCC::SignedLessThan, x, 0);
            let inv = self.b.ins().bnot(x);
            self.b.ins().select(neg, inv, x)
        } else {
            x
        };
        let lz = self.b.ins().clz(v);
        let thirty_one = self.b.ins().iconst(I32, 31);
        let bit = self.b.ins().isub(thirty_one, lz);
        let none = self.b.ins().iconst(I32, u32::MAX as i64);
        let zero = self.b.ins().icmp_imm_u(IntCC::Equal, v, 0);
        self.b.ins().select(zero, none, bit)
    }

    /// `extractBits(e, offset, count)`: `o = min(offset, 32)`, `c = min(count, 32 - o)`;
    /// bits `o..o + c` moved down, sign-extended for i32; 0 when `c = 0`.
    fn extract_bits(&mut self, leaf: Leaf, e: Value, offset: Value, count: Value) -> Value {
        let (o, c) = self.bit_range(offset, count);
        let thirty_two = self.b.ins().iconst(I32, 32);
        let oc = self.b.ins().iadd(o, c);
        let up = self.b.ins().isub(thirty_two, oc);
        let down = self.b.ins().isub(thirty_two, c);
        let shifted = self.b.ins().ishl(e, up);
        let r = if leaf == Leaf::I32 {
            self.b.ins().sshr(shifted, down)
        } else {
            self.b.ins().ushr(shifted, down)
        };
        let empty = self.b.ins().icmp_imm_u(IntCC::Equal, c, 0);
        let zero = self.b.ins().iconst(I32, 0);
        self.b.ins().select(empty, zero, r)
    }

    /// `insertBits(e, newbits, offset, count)`.
    fn insert_bits(&mut self, e: Value, new: Value, offset: Value, count: Value) -> Value {
        let (o, c) = self.bit_range(offset, count);
        let thirty_two = self.b.ins().iconst(I32, 32);
        let all = self.b.ins().iconst(I32, u32::MAX as i64);
        let down = self.b.ins().isub(thirty_two, c);
        let low = self.b.ins().ushr(all, down);
        let mask = self.b.ins().ishl(low, o);
        let empty = self.b.ins().icmp_imm_u(IntCC::Equal, c, 0);
        let zero = self.b.ins().iconst(I32, 0);
        let mask = self.b.ins().select(empty, zero, mask);
        let keep = self.b.ins().band_not(e, mask);
        let moved = self.b.ins().ishl(new, o);
        let put = self.b.ins().band(moved, mask);
        self.b.ins().bor(keep, put)
    }

    fn bit_range(&mut self, offset: Value, count: Value) -> (Value, Value) {
        let thirty_two = self.b.ins().iconst(I32, 32);
        let o = self.b.ins().umin(offset, thirty_two);
        let room = self.b.ins().isub(thirty_two, o);
        let c = self.b.ins().umin(count, room);
        (o, c)
    }

    /// `pack4x8unorm`: `floor(0.5 + 255 * clamp(e, 0, 1))` per byte.
    fn pack4x8unorm(&mut self, v: &[Value]) -> Value {
        let mut acc = self.b.ins().iconst(I32, 0);
        for (i, &x) in v.iter().enumerate() {
            let zero = self.b.ins().f32const(0.0);
            let one = self.b.ins().f32const(1.0);
            let scale = self.b.ins().f32const(255.0);
            let half = self.b.ins().f32const(0.5);
            let lo = self.max(Leaf::F32, x, zero);
            let c = self.min(Leaf::F32, lo, one);
            let s = self.b.ins().fmul(scale, c);
            let r = self.b.ins().fadd(half, s);
            let f = self.b.ins().floor(r);
            let u = self.b.ins().fcvt_to_uint_sat(I32, f);
            let byte = self.b.ins().band_imm_u(u, 0xff);
            let placed = self.b.ins().ishl_imm_u(byte, 8 * i as i64);
            acc = self.b.ins().bor(acc, placed);
        }
        acc
    }

    /// Calls an unpacking host function that writes `n` leaves of `ty` to scratch.
    fn unpack(
        &mut self,
        f: HostFn,
        x: Value,
        ty: cranelift_codegen::ir::Type,
        n: usize,
    ) -> Vec<Value> {
        let out = self.scratch_addr();
        self.call_host(f, &[x, out]);
        (0..n)
            .map(|i| {
                self.b
                    .ins()
                    .load(ty, MemFlagsData::trusted(), out, 4 * i as i32)
            })
            .collect()
    }
}
