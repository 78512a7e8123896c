//! Compile-time worst-case encoded sizes.
//!
//! Every wire type states how many bytes its postcard encoding can take at most, so frame
//! buffers are sized by `const` arithmetic and checked by `const` assertions instead of at run
//! time. postcard's own `MaxSize` derive only covers heapless 0.7, so this small trait replaces it.
//! Integers are varints on the wire: the worst case of a `u16` is 3 bytes, `u32` 5, `u64` 10,
//! and a zig-zag `i32` 5. An enum costs its discriminant varint plus its largest variant.

use heapless::Vec;

/// A type whose postcard encoding never exceeds `MAX_SIZE` bytes.
pub trait MaxSize {
    /// Upper bound, in bytes, of the postcard encoding of any value of this type.
    const MAX_SIZE: usize;
}

/// Worst-case length in bytes of a postcard varint holding a value of `bits` bits.
pub const fn varint_max_bytes(bits: usize) -> usize {
    bits.div_ceil(7)
}

/// Length in bytes of the postcard varint encoding of `value`.
pub const fn varint_len_bytes(value: usize) -> usize {
    let mut len = 1;
    let mut rest = value >> 7;
    while rest != 0 {
        len += 1;
        rest >>= 7;
    }
    len
}

/// Bytes taken by an enum discriminant when the enum has `variant_count` variants.
pub const fn discriminant_bytes(variant_count: usize) -> usize {
    varint_len_bytes(variant_count.saturating_sub(1))
}

/// The larger of two sizes (`core::cmp::max` is not `const` for `usize` on every toolchain we
/// support).
pub const fn max(a: usize, b: usize) -> usize {
    if a > b { a } else { b }
}

/// The largest of a list of sizes.
pub const fn max_of(sizes: &[usize]) -> usize {
    let mut best = 0;
    let mut i = 0;
    while i < sizes.len() {
        best = max(best, sizes[i]);
        i += 1;
    }
    best
}

macro_rules! impl_max_size {
    ($($ty:ty => $size:expr),* $(,)?) => {
        $(impl MaxSize for $ty {
            const MAX_SIZE: usize = $size;
        })*
    };
}

impl_max_size! {
    () => 0,
    bool => 1,
    u8 => 1,
    i8 => 1,
    u16 => varint_max_bytes(16),
    i16 => varint_max_bytes(16),
    u32 => varint_max_bytes(32),
    i32 => varint_max_bytes(32),
    u64 => varint_max_bytes(64),
    i64 => varint_max_bytes(64),
}

impl<T: MaxSize> MaxSize for &T {
    const MAX_SIZE: usize = T::MAX_SIZE;
}

impl<T: MaxSize> MaxSize for Option<T> {
    const MAX_SIZE: usize = 1 + T::MAX_SIZE;
}

impl<T: MaxSize, const N: usize> MaxSize for Vec<T, N> {
    const MAX_SIZE: usize = varint_len_bytes(N) + N * T::MAX_SIZE;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn varint_worst_cases_match_postcard() {
        let mut buf = [0u8; 16];
        assert_eq!(postcard::to_slice(&u16::MAX, &mut buf).map(|b| b.len()), Ok(u16::MAX_SIZE));
        assert_eq!(postcard::to_slice(&u32::MAX, &mut buf).map(|b| b.len()), Ok(u32::MAX_SIZE));
        assert_eq!(postcard::to_slice(&u64::MAX, &mut buf).map(|b| b.len()), Ok(u64::MAX_SIZE));
        assert_eq!(postcard::to_slice(&i32::MIN, &mut buf).map(|b| b.len()), Ok(i32::MAX_SIZE));
        assert_eq!(postcard::to_slice(&i64::MIN, &mut buf).map(|b| b.len()), Ok(i64::MAX_SIZE));
    }

    #[test]
    fn varint_len_bytes_matches_postcard() {
        let mut buf = [0u8; 16];
        for value in [0usize, 1, 127, 128, 16_383, 16_384, 2_097_151, 2_097_152] {
            let encoded = postcard::to_slice(&(value as u32), &mut buf).map(|b| b.len());
            assert_eq!(encoded, Ok(varint_len_bytes(value)), "value {value}");
        }
    }

    #[test]
    fn full_heapless_vec_is_within_bound() {
        let mut v: Vec<u8, 200> = Vec::new();
        v.resize(200, 0xFF).expect("capacity is 200");
        let mut buf = [0u8; 256];
        let len = postcard::to_slice(&v, &mut buf).map(|b| b.len());
        assert_eq!(len, Ok(<Vec<u8, 200>>::MAX_SIZE));
    }
}
