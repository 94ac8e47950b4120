//! Adaptive binary range coder and the integer models built on it.
//!
//! The coder is the carry-less-by-cache range coder of LZMA (Igor Pavlov,
//! public domain): 32-bit range, 11-bit probabilities adapted by a shift of
//! `ADAPT_SHIFT` after every bit. It is a few dozen lines and what it
//! codes is ours: the codec's model is the choice of *which* adaptive
//! context each bit goes through ([`IntModel`]). Measured against zstd -19
//! on the same integer streams it is what makes the residuals small (see
//! docs/reference.md, "Compression, measured"); a general-purpose compressor cannot
//! learn that the third bit of a chord length is nearly always 1.
//!
//! Integers are binarised as in CABAC's Exp-Golomb scheme: a zero flag, a
//! sign, the bit length of the magnitude in unary (one context per
//! position), the first `MODELLED_MANTISSA` bits below the leading one in
//! contexts of (length, position), the rest at probability one half.

/// Probability precision: probabilities are `p / 2^15` that the bit is 0
/// (model 8 on; models 6 and 7: `p / 2^11`).
const PROB_BITS: u32 = 15;
const LEGACY_PROB_BITS: u32 = 11;
/// Models 6 and 7 adapt every context by 1/2^5 after every bit (LZMA's
/// choice).
const LEGACY_SHIFT: u32 = 5;
/// Model 8 on: a context's `n`-th update (from 0) moves it by
/// `1/2^min(1 + ⌊log₂(n + 1)⌋, 6)`: 1/2, 1/4, 1/4, 1/8, … — about the
/// running frequency `1/(n + 2)` of the Krichevsky–Trofimov estimator at
/// first, so a context learns from its first few bits (a block of a small
/// file codes a few hundred values per field: 1–7 % smaller there), then a
/// fixed window of about 64 bits, which the finer 15-bit probabilities
/// allow (0.5 % smaller on large files). 5 as the last shift, or a mix of
/// a fast and a slow estimate, measured no better.
const ADAPT_SHIFT_MAX: u32 = 6;
/// `Bit::n` of a context that adapts as in models 6 and 7.
const LEGACY: u8 = u8::MAX;
const TOP: u32 = 1 << 24;
/// Bytes a decoder may read past the end of a valid stream.
const SLACK: usize = 8;

/// Largest bit length of a coded magnitude: values up to `2^40 - 1`.
pub const MAX_BITS: usize = 40;
/// Mantissa bits (below the leading one) coded in adaptive contexts (3
/// measured 0.1–0.6 % smaller on the field lines, as much larger on the
/// small files: more contexts learn more slowly).
const MODELLED_MANTISSA: usize = 2;

/// How the contexts of a stream adapt: fixed in codec models 6 and 7,
/// warming up from model 8 on (`ADAPT_SHIFT_MAX`, in this module).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Adaptation {
    /// 11-bit probabilities, each update by 1/32.
    Fixed,
    /// 15-bit probabilities, fast first updates.
    WarmUp,
}

impl Adaptation {
    /// The scheme of codec model `model`.
    ///
    /// ```
    /// use strandfit::codec::entropy::{Adaptation, Decoder, Encoder, IntModel};
    ///
    /// // The same values coded under both schemes decode under their own,
    /// // and the warm-up is cheaper on a short, skewed stream.
    /// assert_eq!(Adaptation::of_model(7), Adaptation::Fixed);
    /// assert_eq!(Adaptation::of_model(8), Adaptation::WarmUp);
    /// let vals: Vec<i64> = (0..60).map(|i| if i % 10 == 3 { 2 } else { 0 }).collect();
    /// let size = |a: Adaptation| {
    ///     let (mut m, mut enc) = (IntModel::default(), Encoder::with_adaptation(a));
    ///     vals.iter().for_each(|&v| m.put(&mut enc, v));
    ///     let bytes = enc.finish();
    ///     let (mut m, mut dec) = (IntModel::default(), Decoder::with_adaptation(&bytes, a));
    ///     assert!(vals.iter().all(|&v| m.get(&mut dec) == v));
    ///     bytes.len()
    /// };
    /// assert!(size(Adaptation::WarmUp) < size(Adaptation::Fixed));
    /// ```
    pub fn of_model(model: u8) -> Self {
        if model >= 8 {
            Adaptation::WarmUp
        } else {
            Adaptation::Fixed
        }
    }
}

/// One adaptive binary context. Fresh (`Default`: probability one half,
/// no updates, as a stream of the current model starts it) until the
/// coder first uses it; a stream of [`Adaptation::Fixed`] turns a fresh
/// context into its own kind on first use.
#[derive(Clone, Copy, Debug)]
pub struct Bit {
    /// Probability of a 0 in units of `2^-PROB_BITS` (`2^-11` when
    /// `n == LEGACY`).
    p: u16,
    /// Updates so far (saturating below [`LEGACY`]), or [`LEGACY`].
    n: u8,
}

impl Default for Bit {
    fn default() -> Self {
        Bit {
            p: 1 << (PROB_BITS - 1),
            n: 0,
        }
    }
}

impl Bit {
    /// A fresh context made a [`Adaptation::Fixed`] one (11-bit, one half);
    /// one already so is left as it is. Under `Fixed` every context is
    /// either fresh (`n == 0`) or `LEGACY`.
    #[inline]
    fn legacy(&mut self) {
        if self.n != LEGACY {
            *self = Bit {
                p: 1 << (LEGACY_PROB_BITS - 1),
                n: LEGACY,
            };
        }
    }

    #[inline]
    fn prob_bits(self) -> u32 {
        if self.n == LEGACY {
            LEGACY_PROB_BITS
        } else {
            PROB_BITS
        }
    }

    /// Ideal cost in 1/256 bits of coding `bit` in this context now (for the
    /// encoder's choices; the state is not changed). A fresh context: one
    /// bit (its probability is one half under either adaptation).
    pub fn cost(self, bit: bool) -> u32 {
        let p0 = self.p as f64 / (1u32 << self.prob_bits()) as f64;
        let p = if bit { 1.0 - p0 } else { p0 };
        (-p.log2() * 256.0) as u32
    }

    #[inline]
    fn update(&mut self, bit: bool) {
        // The shift and the next count from tables indexed by the count
        // (the same values as `(1 + ilog2(n + 1)).min(ADAPT_SHIFT_MAX)` and
        // `(n + 1).min(LEGACY − 1)`; `LEGACY` maps to itself and its shift).
        let shift = UPDATE_SHIFT[self.n as usize] as u32;
        self.n = NEXT_COUNT[self.n as usize];
        let one = 1u16 << self.prob_bits();
        // Both moves, one selected by a mask: a branch on the bit would be
        // mispredicted about as often as the bit is hard to predict.
        let mask = (bit as u16).wrapping_neg();
        let down = self.p >> shift;
        let up = (one - self.p) >> shift;
        self.p = self.p.wrapping_sub(down & mask).wrapping_add(up & !mask);
    }
}

impl Bit {
    /// [`Bit::update`] of a context of [`Adaptation::WarmUp`] (never
    /// `LEGACY`): the probability always in `PROB_BITS`.
    #[inline]
    fn update_warm(&mut self, bit: bool) {
        // One load for both (a bit's update is on the decoder's chain).
        let step = UPDATE_STEP[self.n as usize];
        let shift = (step & 0xff) as u32;
        self.n = (step >> 8) as u8;
        let mask = (bit as u16).wrapping_neg();
        let down = self.p >> shift;
        let up = ((1u16 << PROB_BITS) - self.p) >> shift;
        self.p = self.p.wrapping_sub(down & mask).wrapping_add(up & !mask);
    }
}

/// [`Bit::update`]'s shift for each count.
const UPDATE_SHIFT: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut n = 0;
    while n < 256 {
        t[n] = if n == LEGACY as usize {
            LEGACY_SHIFT as u8
        } else {
            let s = 1 + (n as u32 + 1).ilog2();
            (if s < ADAPT_SHIFT_MAX {
                s
            } else {
                ADAPT_SHIFT_MAX
            }) as u8
        };
        n += 1;
    }
    t
};

/// [`UPDATE_SHIFT`] and [`NEXT_COUNT`] of each count in one entry (the
/// next count in the high byte).
const UPDATE_STEP: [u16; 256] = {
    let mut t = [0u16; 256];
    let mut n = 0;
    while n < 256 {
        t[n] = (NEXT_COUNT[n] as u16) << 8 | UPDATE_SHIFT[n] as u16;
        n += 1;
    }
    t
};

/// [`Bit::update`]'s next count for each count.
const NEXT_COUNT: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut n = 0;
    while n < 256 {
        t[n] = if n == LEGACY as usize {
            LEGACY
        } else if n + 1 < LEGACY as usize - 1 {
            (n + 1) as u8
        } else {
            LEGACY - 1
        };
        n += 1;
    }
    t
};

/// The encoding half of the range coder.
pub struct Encoder {
    low: u64,
    range: u32,
    cache: u8,
    cache_size: u64,
    out: Vec<u8>,
    /// Ideal bits spent per tag (for measuring where a stream's bytes go;
    /// off unless [`Encoder::with_tally`]).
    tally: Option<Vec<f64>>,
    tag: usize,
    adaptation: Adaptation,
}

impl Default for Encoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Encoder {
    /// An encoder whose contexts adapt as in the current codec model.
    pub fn new() -> Self {
        Self::with_adaptation(Adaptation::WarmUp)
    }

    /// An encoder whose contexts adapt by `adaptation`.
    pub fn with_adaptation(adaptation: Adaptation) -> Self {
        Encoder {
            low: 0,
            range: u32::MAX,
            cache: 0,
            cache_size: 1,
            out: Vec::new(),
            tally: None,
            tag: 0,
            adaptation,
        }
    }

    /// An encoder that also adds up the ideal cost of every bit under the
    /// tag last set by [`set_tag`](Self::set_tag) (`tags` of them).
    pub fn with_tally(tags: usize, adaptation: Adaptation) -> Self {
        let mut e = Self::with_adaptation(adaptation);
        e.tally = Some(vec![0.0; tags]);
        e
    }

    /// Attributes the bits coded from now on to `tag` (when tallying).
    pub fn set_tag(&mut self, tag: usize) {
        self.tag = tag;
    }

    /// Bits written so far, to about a tenth of a bit: the bytes out and
    /// pending, less what the range still leaves open (`log₂ range` with
    /// its mantissa taken linearly, from the float's bits: no libm call, so
    /// every platform makes the same encoder choices from it). Differences
    /// of it measure what a stretch of the stream cost.
    ///
    /// ```
    /// use strandfit::codec::entropy::{Bit, Encoder};
    ///
    /// let mut enc = Encoder::new();
    /// let start = enc.position_bits();
    /// let mut flag = Bit::default();
    /// for _ in 0..1000 {
    ///     enc.bit(&mut flag, false); // a context that learns: nearly free
    /// }
    /// let spent = enc.position_bits() - start;
    /// assert!(spent > 0.0 && spent < 40.0, "{spent}");
    /// ```
    pub fn position_bits(&self) -> f64 {
        8.0 * (self.out.len() as f64 + self.cache_size as f64) - linear_log2(self.range as f64)
    }

    /// The ideal bits per tag so far, if tallying.
    pub fn tally(&self) -> Option<&[f64]> {
        self.tally.as_deref()
    }

    fn shift_low(&mut self) {
        if (self.low as u32) < 0xFF00_0000 || (self.low >> 32) != 0 {
            let carry = (self.low >> 32) as u8;
            let mut temp = self.cache;
            loop {
                self.out.push(temp.wrapping_add(carry));
                temp = 0xFF;
                self.cache_size -= 1;
                if self.cache_size == 0 {
                    break;
                }
            }
            self.cache = ((self.low as u32) >> 24) as u8;
        }
        self.cache_size += 1;
        self.low = ((self.low as u32) << 8) as u64;
    }

    /// Codes `bit` in the adaptive context `ctx`.
    #[inline(always)]
    pub fn bit(&mut self, ctx: &mut Bit, bit: bool) {
        if self.adaptation == Adaptation::Fixed || self.tally.is_some() {
            return self.bit_slow(ctx, bit);
        }
        // As the decoder's `bit`: a context of the current model is never
        // `LEGACY`, so its probability is in `PROB_BITS`.
        self.encode((self.range >> PROB_BITS) * ctx.p as u32, bit);
        ctx.update_warm(bit);
    }

    /// [`bit`](Self::bit) in a stream of [`Adaptation::Fixed`], or tallied.
    #[cold]
    #[inline(never)]
    fn bit_slow(&mut self, ctx: &mut Bit, bit: bool) {
        if self.adaptation == Adaptation::Fixed {
            ctx.legacy();
        }
        if let Some(t) = self.tally.as_mut() {
            t[self.tag] += ctx.cost(bit) as f64 / 256.0;
        }
        self.encode((self.range >> ctx.prob_bits()) * ctx.p as u32, bit);
        ctx.update(bit);
    }

    /// `bit`, whose 0 takes the range's first `bound`; the range then
    /// renormalised.
    #[inline]
    fn encode(&mut self, bound: u32, bit: bool) {
        // Without a branch on the bit (as the decoder's `decide`).
        let mask = (bit as u32).wrapping_neg();
        self.low += (bound & mask) as u64;
        self.range = (self.range.wrapping_sub(bound) & mask) | (bound & !mask);
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    /// Codes the low `n` bits of `v` at probability one half, high first.
    pub fn direct(&mut self, v: u64, n: usize) {
        if self.adaptation == Adaptation::WarmUp && self.tally.is_none() {
            // `bit` in a fresh context (probability exactly one half, in
            // `PROB_BITS`), its update dropped: the same bounds.
            for k in (0..n).rev() {
                self.encode(
                    (self.range >> PROB_BITS) << (PROB_BITS - 1),
                    (v >> k) & 1 == 1,
                );
            }
            return;
        }
        for k in (0..n).rev() {
            let mut half = Bit::default();
            self.bit(&mut half, (v >> k) & 1 == 1);
        }
    }

    /// Flushes the coder and returns the bytes. Any value in
    /// `[low, low + range)` ends the stream; the one with the most trailing
    /// zero bits is taken, and its trailing zero bytes are left out (the
    /// decoder reads zeros past the end): about three bytes per stream.
    pub fn finish(mut self) -> Vec<u8> {
        for shift in (0..32).rev() {
            let mask = (1u64 << shift) - 1;
            let v = (self.low + mask) & !mask;
            if v < self.low + self.range as u64 {
                self.low = v;
                break;
            }
        }
        for _ in 0..5 {
            self.shift_low();
        }
        // Only the flush's own zeros: the decoder allows `SLACK` bytes.
        for _ in 0..4 {
            if self.out.len() > 1 && self.out.last() == Some(&0) {
                self.out.pop();
            }
        }
        self.out
    }
}

/// The decoding half. Reading past the end yields zero bytes and sets
/// [`overrun`](Self::overrun), which callers turn into an error (a valid
/// stream is consumed within its length).
pub struct Decoder<'a> {
    data: &'a [u8],
    pos: usize,
    range: u32,
    code: u32,
    overrun: bool,
    adaptation: Adaptation,
}

impl<'a> Decoder<'a> {
    /// A decoder of a stream coded with the current model's adaptation.
    pub fn new(data: &'a [u8]) -> Self {
        Self::with_adaptation(data, Adaptation::WarmUp)
    }

    /// A decoder of a stream whose contexts adapt by `adaptation`.
    pub fn with_adaptation(data: &'a [u8], adaptation: Adaptation) -> Self {
        let mut d = Decoder {
            data,
            pos: 0,
            range: u32::MAX,
            code: 0,
            overrun: false,
            adaptation,
        };
        for _ in 0..5 {
            d.code = (d.code << 8) | d.byte() as u32;
        }
        d
    }

    #[inline]
    fn byte(&mut self) -> u8 {
        match self.data.get(self.pos) {
            Some(&b) => {
                self.pos += 1;
                b
            }
            None => {
                // Past the end the stream's left-out trailing zeros are
                // read (see `Encoder::finish`): up to the five bytes of the
                // flush, and the decoder may look a few bytes ahead.
                if self.pos > self.data.len() + SLACK {
                    self.overrun = true;
                }
                self.pos += 1;
                0
            }
        }
    }

    /// Whether the decoder read beyond the stream (a truncated or corrupt
    /// stream).
    pub fn overrun(&self) -> bool {
        self.overrun || self.pos > self.data.len() + SLACK
    }

    #[inline]
    pub fn bit(&mut self, ctx: &mut Bit) -> bool {
        if self.adaptation == Adaptation::Fixed {
            return self.legacy_bit(ctx);
        }
        let bit = self.decide((self.range >> PROB_BITS) * ctx.p as u32);
        ctx.update_warm(bit);
        bit
    }

    /// [`bit`](Self::bit) in a stream of [`Adaptation::Fixed`].
    #[cold]
    #[inline(never)]
    fn legacy_bit(&mut self, ctx: &mut Bit) -> bool {
        ctx.legacy();
        let bit = self.decide((self.range >> LEGACY_PROB_BITS) * ctx.p as u32);
        ctx.update(bit);
        bit
    }

    /// The bit whose 0 takes the range's first `bound`, the range then
    /// renormalised.
    #[inline]
    fn decide(&mut self, bound: u32) -> bool {
        let bit = self.code >= bound;
        // Both outcomes computed, then selected (conditional moves): the
        // next decision waits on one compare, not on a mask built from it.
        let (code, range) = if bit {
            (
                self.code.wrapping_sub(bound),
                self.range.wrapping_sub(bound),
            )
        } else {
            (self.code, bound)
        };
        self.code = code;
        self.range = range;
        self.normalise();
        bit
    }

    #[inline]
    fn normalise(&mut self) {
        while self.range < TOP {
            self.range <<= 8;
            self.code = (self.code << 8) | self.byte() as u32;
        }
    }

    /// `n` bits at probability one half, high first: as [`bit`](Self::bit)
    /// in a fresh context each, whose probability is exactly one half.
    pub fn direct(&mut self, n: usize) -> u64 {
        let bits = match self.adaptation {
            Adaptation::Fixed => LEGACY_PROB_BITS,
            Adaptation::WarmUp => PROB_BITS,
        };
        let mut v = 0u64;
        for _ in 0..n {
            let bit = self.decide((self.range >> bits) << (bits - 1));
            v = (v << 1) | bit as u64;
        }
        v
    }
}

/// Adaptive model of one integer field (signed or unsigned).
#[derive(Clone, Debug)]
pub struct IntModel {
    zero: Bit,
    sign: Bit,
    /// Sign contexts by a sign seen before (−, +) ([`IntModel::put_after`]).
    signs: [Bit; 2],
    len: [Bit; MAX_BITS + 1],
    /// Mantissa bits below the leading one coded in contexts of (length,
    /// the bits before): [`MODELLED_MANTISSA`], or more for a field of a
    /// few recurring values ([`IntModel::with_mantissa`]).
    modelled: usize,
    /// `(MAX_BITS + 1) << modelled` contexts: length `n`, tree node.
    mantissa: Vec<Bit>,
}

impl Default for IntModel {
    fn default() -> Self {
        Self::with_mantissa(MODELLED_MANTISSA)
    }
}

impl IntModel {
    /// A model whose first `modelled` mantissa bits (below the leading
    /// one, at most 8) are coded in contexts: with all of a value's bits
    /// modelled, a value that recurs (a point count of a resampled file)
    /// costs a fraction of a bit.
    ///
    /// ```
    /// use strandfit::codec::entropy::{Encoder, IntModel};
    ///
    /// // 200 curves of 100 points: under 16 bytes with every bit of the
    /// // count in contexts, over 50 with the default two (the two low bits
    /// // of 99 then go raw).
    /// let size = |modelled| {
    ///     let (mut m, mut enc) = (IntModel::with_mantissa(modelled), Encoder::new());
    ///     (0..200).for_each(|_| m.put_unsigned(&mut enc, 99));
    ///     enc.finish().len()
    /// };
    /// assert!(size(6) < 16, "{}", size(6));
    /// assert!(size(2) > 50, "{}", size(2));
    /// ```
    pub fn with_mantissa(modelled: usize) -> Self {
        let modelled = modelled.min(8);
        IntModel {
            zero: Bit::default(),
            sign: Bit::default(),
            signs: [Bit::default(); 2],
            len: [Bit::default(); MAX_BITS + 1],
            modelled,
            mantissa: vec![Bit::default(); (MAX_BITS + 1) << modelled],
        }
    }
}

/// Bit length of `m > 0`.
fn bit_len(m: u64) -> usize {
    64 - m.leading_zeros() as usize
}

/// `log₂ y` of a positive, normal `y` with the mantissa taken linearly:
/// `e + (m − 1)` for `y = 2^e · m`, `1 ≤ m < 2`, read off the float's bits
/// (exact at powers of two, increasing, at most 0.09 below `log₂ y`). No
/// libm call, so every platform makes the same encoder choices from it, and
/// no division: the slide's cost calls it ~150 times per vertex.
///
/// ```
/// use strandfit::codec::entropy::linear_log2;
///
/// assert_eq!(linear_log2(8.0), 3.0);
/// assert_eq!(linear_log2(12.0), 3.5); // log₂ 12 = 3.585
/// assert!((1..1000).all(|k| {
///     let y = k as f64;
///     let e = y.log2() - linear_log2(y);
///     (0.0..0.09).contains(&e) && linear_log2(y + 1.0) > linear_log2(y)
/// }));
/// ```
pub const fn linear_log2(y: f64) -> f64 {
    let bits = y.to_bits();
    let exponent = (bits >> 52) as i64 - 1023;
    let mantissa = f64::from_bits((bits & ((1u64 << 52) - 1)) | (1023u64 << 52));
    exponent as f64 + (mantissa - 1.0)
}

/// Whether `v` can be coded (`|v| < 2^MAX_BITS`).
pub fn codable(v: i64) -> bool {
    v.unsigned_abs() < (1u64 << MAX_BITS)
}

/// Which context a value's sign is coded in.
enum SignContext<'a> {
    /// The model's own: the plain one where the value before (on the same
    /// axis or field) was 0 or there was none, else one each for − and +.
    After(i64),
    /// One the caller keeps.
    In(&'a mut Bit),
}

impl IntModel {
    /// Codes `v`; `|v|` must be below `2^MAX_BITS` (see [`codable`]).
    #[inline]
    pub fn put(&mut self, enc: &mut Encoder, v: i64) {
        self.put_with(enc, v, SignContext::After(0));
    }

    /// Codes `v`, its sign in a context of `before`'s sign (the plain
    /// sign context where `before` is 0, so `put_after(enc, v, 0)` is
    /// `put(enc, v)`).
    ///
    /// ```
    /// use strandfit::codec::entropy::{Decoder, Encoder, IntModel};
    ///
    /// // Signs in stretches of six, as often + as −: a bit each without a
    /// // context, about two thirds of one after the sign before (a
    /// // sixth of them change), which is a quarter of these values' bytes.
    /// let vals: Vec<i64> = (0..600).map(|i| if (i / 6) % 2 == 0 { 3 } else { -3 }).collect();
    /// let (mut plain, mut after) = (IntModel::default(), IntModel::default());
    /// let (mut e1, mut e2) = (Encoder::new(), Encoder::new());
    /// for (k, &v) in vals.iter().enumerate() {
    ///     plain.put(&mut e1, v);
    ///     after.put_after(&mut e2, v, if k > 0 { vals[k - 1] } else { 0 });
    /// }
    /// let (b1, b2) = (e1.finish(), e2.finish());
    /// assert!(4 * b2.len() < 3 * b1.len(), "{} B after the sign before, {} B plain", b2.len(), b1.len());
    /// let (mut m, mut dec) = (IntModel::default(), Decoder::new(&b2));
    /// let mut before = 0;
    /// for &v in &vals {
    ///     let got = m.get_after(&mut dec, before);
    ///     assert_eq!(got, v);
    ///     before = got;
    /// }
    /// ```
    #[inline]
    pub fn put_after(&mut self, enc: &mut Encoder, v: i64, before: i64) {
        self.put_with(enc, v, SignContext::After(before));
    }

    /// [`put_after`](Self::put_after)'s decoder.
    #[inline]
    pub fn get_after(&mut self, dec: &mut Decoder, before: i64) -> i64 {
        self.get_with(dec, SignContext::After(before))
    }

    /// Codes `v`, its sign in the context `sign` (kept by the caller).
    #[inline]
    pub fn put_signed_in(&mut self, enc: &mut Encoder, v: i64, sign: &mut Bit) {
        self.put_with(enc, v, SignContext::In(sign));
    }

    /// [`put_signed_in`](Self::put_signed_in)'s decoder.
    #[inline]
    pub fn get_signed_in(&mut self, dec: &mut Decoder, sign: &mut Bit) -> i64 {
        self.get_with(dec, SignContext::In(sign))
    }

    /// The sign's context.
    #[inline]
    fn sign_bit<'a>(
        sign: &'a mut Bit,
        signs: &'a mut [Bit; 2],
        which: SignContext<'a>,
    ) -> &'a mut Bit {
        match which {
            SignContext::After(before) => match before.signum() {
                0 => sign,
                s => &mut signs[(s > 0) as usize],
            },
            SignContext::In(bit) => bit,
        }
    }

    /// Codes `v`: its zero flag, its sign in `which`, its magnitude.
    #[inline]
    fn put_with(&mut self, enc: &mut Encoder, v: i64, which: SignContext) {
        enc.bit(&mut self.zero, v != 0);
        if v == 0 {
            return;
        }
        enc.bit(
            Self::sign_bit(&mut self.sign, &mut self.signs, which),
            v < 0,
        );
        self.put_magnitude(enc, v.unsigned_abs());
    }

    /// [`put_with`](Self::put_with)'s decoder.
    #[inline(always)]
    fn get_with(&mut self, dec: &mut Decoder, which: SignContext) -> i64 {
        if !dec.bit(&mut self.zero) {
            return 0;
        }
        let neg = dec.bit(Self::sign_bit(&mut self.sign, &mut self.signs, which));
        let m = self.get_magnitude(dec) as i64;
        if neg {
            -m
        } else {
            m
        }
    }

    /// Codes `v ≥ 0` (no sign bit).
    pub fn put_unsigned(&mut self, enc: &mut Encoder, v: u64) {
        enc.bit(&mut self.zero, v != 0);
        if v != 0 {
            self.put_magnitude(enc, v);
        }
    }

    fn put_magnitude(&mut self, enc: &mut Encoder, m: u64) {
        debug_assert!(m > 0 && m < (1u64 << MAX_BITS));
        let n = bit_len(m);
        for k in 1..n {
            enc.bit(&mut self.len[k], true);
        }
        if n < MAX_BITS {
            enc.bit(&mut self.len[n], false);
        }
        // Mantissa below the leading one: the first bits in contexts.
        let below = n - 1;
        let modelled = below.min(self.modelled);
        let mut node = 1usize;
        for k in 0..modelled {
            let b = (m >> (below - 1 - k)) & 1 == 1;
            enc.bit(&mut self.mantissa[n << self.modelled | node], b);
            node = (node << 1 | b as usize) & ((1 << self.modelled) - 1);
        }
        enc.direct(m, below - modelled);
    }

    #[inline]
    pub fn get(&mut self, dec: &mut Decoder) -> i64 {
        self.get_with(dec, SignContext::After(0))
    }

    pub fn get_unsigned(&mut self, dec: &mut Decoder) -> u64 {
        if !dec.bit(&mut self.zero) {
            return 0;
        }
        self.get_magnitude(dec)
    }

    #[inline(always)]
    fn get_magnitude(&mut self, dec: &mut Decoder) -> u64 {
        let mut n = 1;
        while n < MAX_BITS && dec.bit(&mut self.len[n]) {
            n += 1;
        }
        let below = n - 1;
        let modelled = below.min(self.modelled);
        let mut m = 1u64;
        let mut node = 1usize;
        for _ in 0..modelled {
            let b = dec.bit(&mut self.mantissa[n << self.modelled | node]);
            m = m << 1 | b as u64;
            node = (node << 1 | b as usize) & ((1 << self.modelled) - 1);
        }
        let rest = below - modelled;
        (m << rest) | dec.direct(rest)
    }

    /// Approximate cost of coding `v` now, in 1/256 bits (no state change).
    pub fn cost(&self, v: i64) -> u32 {
        let mut c = self.zero.cost(v != 0);
        if v == 0 {
            return c;
        }
        c += self.sign.cost(v < 0);
        let m = v.unsigned_abs().min((1u64 << MAX_BITS) - 1);
        let n = bit_len(m);
        for k in 1..n {
            c += self.len[k].cost(true);
        }
        if n < MAX_BITS {
            c += self.len[n].cost(false);
        }
        c + 256 * (n as u32 - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The update tables are the formulas they replace.
    #[test]
    fn the_update_tables_are_their_formulas() {
        for n in 0..=255u8 {
            let (shift, next) = if n == LEGACY {
                (LEGACY_SHIFT, LEGACY)
            } else {
                (
                    (1 + (n as u32 + 1).ilog2()).min(ADAPT_SHIFT_MAX),
                    n.saturating_add(1).min(LEGACY - 1),
                )
            };
            assert_eq!(
                (UPDATE_SHIFT[n as usize] as u32, NEXT_COUNT[n as usize]),
                (shift, next),
                "count {n}"
            );
            let step = UPDATE_STEP[n as usize];
            assert_eq!(((step & 0xff) as u32, (step >> 8) as u8), (shift, next));
        }
    }

    /// `position_bits` tracks the stream: never decreasing, within a few
    /// bytes of the finished length, and each stretch within a bit of the
    /// ideal cost (the tally's `−log₂ p`) of what it coded.
    #[test]
    fn position_bits_follow_the_stream_and_the_ideal_cost() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut enc = Encoder::with_tally(1, Adaptation::WarmUp);
        let mut models = vec![IntModel::default(); 2];
        let mut last = enc.position_bits();
        let mut stretches = Vec::new();
        for round in 0..200 {
            let (before, ideal_before) = (enc.position_bits(), enc.tally().unwrap()[0]);
            for _ in 0..rng.gen_range(1..60) {
                let spread = if round % 2 == 0 { 4 } else { 4000 };
                models[round % 2].put(&mut enc, rng.gen_range(-spread..=spread));
                let now = enc.position_bits();
                assert!(now >= last - 1e-9, "{now} < {last}");
                last = now;
            }
            let spent = enc.position_bits() - before;
            let ideal = enc.tally().unwrap()[0] - ideal_before;
            stretches.push((spent, ideal));
        }
        // Each stretch's cost to within the coder's rounding (a range
        // coder pays a small fraction of a bit per coded bit at most).
        for (spent, ideal) in &stretches {
            assert!(
                (spent - ideal).abs() < 1.0 + 0.01 * ideal,
                "{spent} vs {ideal}"
            );
        }
        let end = enc.position_bits();
        let bytes = enc.finish().len() as f64;
        assert!(
            (8.0 * bytes - end).abs() <= 40.0,
            "{} bytes, position {end}",
            bytes
        );
    }

    #[test]
    fn integers_round_trip_in_mixed_models() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let vals: Vec<(usize, i64)> = (0..20_000)
            .map(|i| {
                let bits = rng.gen_range(0..MAX_BITS as u32);
                let m = rng.gen_range(0..(1u64 << bits)) as i64;
                let v = if rng.gen_bool(0.5) { -m } else { m };
                (i % 3, if i % 7 == 0 { 0 } else { v })
            })
            .collect();
        let mut models = vec![IntModel::default(); 3];
        let mut enc = Encoder::new();
        for &(k, v) in &vals {
            if k == 2 {
                models[k].put_unsigned(&mut enc, v.unsigned_abs());
            } else {
                models[k].put(&mut enc, v);
            }
        }
        enc.direct(0b1011, 4);
        let bytes = enc.finish();
        let mut models = vec![IntModel::default(); 3];
        let mut dec = Decoder::new(&bytes);
        for &(k, v) in &vals {
            let got = if k == 2 {
                models[k].get_unsigned(&mut dec) as i64
            } else {
                models[k].get(&mut dec)
            };
            let want = if k == 2 { v.abs() } else { v };
            assert_eq!(got, want);
        }
        assert_eq!(dec.direct(4), 0b1011);
        assert!(!dec.overrun());
    }

    #[test]
    fn skewed_bits_cost_little_and_cost_estimate_is_close() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut enc = Encoder::new();
        let mut m = IntModel::default();
        let mut estimate = 0u64;
        for _ in 0..10_000 {
            // Mostly 0 and ±1: about 1.2 bits each ideally.
            let v = match rng.gen_range(0..10) {
                0..=5 => 0,
                6 | 7 => 1,
                8 => -1,
                _ => 2,
            };
            estimate += m.cost(v) as u64;
            m.put(&mut enc, v);
        }
        let bytes = enc.finish().len() as f64;
        let est = estimate as f64 / 256.0 / 8.0;
        // Entropy of the distribution is 1.57 bits; adaptive coding is close.
        assert!(bytes < 10_000.0 * 1.7 / 8.0, "{bytes} bytes");
        // The estimate counts mantissa bits at one bit each; the coder
        // models the first two, so it is a little cheaper.
        assert!(
            (est - bytes).abs() < 0.1 * bytes,
            "estimate {est} vs {bytes}"
        );
    }

    #[test]
    fn truncated_stream_is_detected_not_a_panic() {
        let mut enc = Encoder::new();
        let mut m = IntModel::default();
        for v in 0..1000 {
            m.put(&mut enc, v * 12345);
        }
        let bytes = enc.finish();
        let cut = &bytes[..bytes.len() / 2];
        let mut m = IntModel::default();
        let mut dec = Decoder::new(cut);
        for _ in 0..1000 {
            m.get(&mut dec);
        }
        assert!(dec.overrun());
    }

    #[test]
    fn a_recurring_value_costs_a_fraction_of_a_bit_with_its_mantissa_modelled() {
        // 19 = 10011b: with two mantissa bits modelled its last two are
        // coded raw (2 bits a value at least); with six, all are learnt.
        // Other values in between still round-trip.
        let vals: Vec<u64> = (0..400)
            .map(|i| if i % 50 == 7 { 300 + i } else { 19 })
            .collect();
        let code = |modelled: usize| {
            let mut m = IntModel::with_mantissa(modelled);
            let mut enc = Encoder::new();
            for &v in &vals {
                m.put_unsigned(&mut enc, v);
            }
            let bytes = enc.finish();
            let mut m = IntModel::with_mantissa(modelled);
            let mut dec = Decoder::new(&bytes);
            for &v in &vals {
                assert_eq!(m.get_unsigned(&mut dec), v);
            }
            assert!(!dec.overrun());
            bytes.len()
        };
        let (two, six) = (code(2), code(6));
        assert!(two >= 400 * 2 / 8, "{two} bytes");
        assert!(six * 3 < two, "six modelled bits: {six} bytes, two: {two}");
    }
}
