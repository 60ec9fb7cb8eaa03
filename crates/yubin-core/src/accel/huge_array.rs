//! Fixed-length arrays of plain data in memory that the OS may back with
//! 2 MiB pages.
//!
//! Incoherent rays on a large mesh land on a different 4 KiB page at
//! nearly every node and leaf; a 50 MB BVH spans 12,000 such pages, more
//! than the TLB holds, so each of those loads also walks the page table.
//! Backed by transparent huge pages the same BVH spans 25 pages. Linux
//! only gives an ordinary allocation huge pages when asked
//! (`/sys/kernel/mm/transparent_hugepage/enabled` is `madvise` by
//! default), so large arrays get their own anonymous mapping, aligned to
//! 2 MiB and advised with `MADV_HUGEPAGE` before it is first written.
//! Embree's allocator asks the same for its BVH. Elsewhere, or when the
//! kernel declines, the mapping is simply made of ordinary pages.

use bytemuck::Pod;
use memmap2::{MmapMut, MmapOptions};
use std::alloc::{handle_alloc_error, Layout};
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use yoke::Yoke;

/// Size and alignment of a transparent huge page (x86-64, and arm64 with
/// 4 KiB base pages).
const HUGE_PAGE: usize = 2 << 20;
/// Arrays from this size on are advised to use huge pages. Getting them
/// can cost the kernel a compaction of physical memory on first touch,
/// which only arrays well beyond the TLB's reach with 4 KiB pages (about
/// 12 MB on a Zen 4 core) earn back in tracing, where otherwise
/// nearly every node and leaf visit would miss the TLB.
const ADVISE_FROM: usize = 16 << 20;
/// Base page size assumed for the memory figure of small arrays.
const PAGE: usize = 4 << 10;

/// [`HugeArray::resident_bytes`] of all live arrays.
static LIVE_BYTES: AtomicUsize = AtomicUsize::new(0);

/// Memory held by all live [`HugeArray`]s, which bypass the global
/// allocator: for memory figures that count the heap with a counting
/// allocator and must add these.
pub fn huge_array_bytes() -> usize {
    LIVE_BYTES.load(Ordering::Relaxed)
}

/// `len` values of `T` in their own mapping, read as a slice. Arrays of
/// at least [`ADVISE_FROM`] bytes are aligned to huge pages and advised to
/// use them. Reading costs what reading a `Vec` costs: the values' slice
/// is kept beside the mapping it borrows from (a [`Yoke`]), not re-derived
/// at each access.
pub struct HugeArray<T: 'static> {
    values: Yoke<&'static [T], Box<MmapMut>>,
    /// Where the values lie in the mapping, in bytes.
    range: Range<usize>,
}

impl<T: Pod> HugeArray<T> {
    /// `len` values, zeroed and then set by `fill`; aborts like `Vec` when
    /// the memory cannot be had.
    pub fn new(len: usize, fill: impl FnOnce(&mut [T])) -> Self {
        let bytes = len
            .checked_mul(std::mem::size_of::<T>())
            .unwrap_or_else(|| out_of_memory(usize::MAX));
        let huge = advised(bytes);
        // Room to slide the start to a huge-page boundary: the slack is
        // address space only, never touched and so never resident.
        let map_len = if huge {
            round_up(bytes, HUGE_PAGE) + HUGE_PAGE
        } else {
            bytes
        };
        let mut map = anonymous_map(map_len);
        let offset = if huge {
            (map.as_ptr() as usize).next_multiple_of(HUGE_PAGE) - map.as_ptr() as usize
        } else {
            0
        };
        if huge {
            advise_huge_pages(&map, offset, round_up(bytes, HUGE_PAGE));
        }
        let range = offset..offset + bytes;
        fill(bytemuck::cast_slice_mut(&mut map[range.clone()]));
        LIVE_BYTES.fetch_add(resident(bytes), Ordering::Relaxed);
        Self {
            values: view(Box::new(map), range.clone()),
            range,
        }
    }

    /// Lets `change` rewrite the values in place.
    pub fn modify(&mut self, change: impl FnOnce(&mut [T])) {
        let placeholder = view(Box::new(anonymous_map(0)), 0..0);
        let mut map = std::mem::replace(&mut self.values, placeholder).into_backing_cart();
        change(bytemuck::cast_slice_mut(&mut map[self.range.clone()]));
        self.values = view(map, self.range.clone());
    }

    /// A copy of `values`.
    pub fn from_slice(values: &[T]) -> Self {
        Self::new(values.len(), |out| out.copy_from_slice(values))
    }
}

impl<T> HugeArray<T> {
    /// Memory the values occupy once written, in whole pages.
    pub fn resident_bytes(&self) -> usize {
        resident(std::mem::size_of_val(&**self))
    }
}

impl<T> std::ops::Deref for HugeArray<T> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        self.values.get()
    }
}

/// The values at `range` of `map`, yoked to it.
fn view<T: Pod>(map: Box<MmapMut>, range: Range<usize>) -> Yoke<&'static [T], Box<MmapMut>> {
    Yoke::attach_to_cart(map, |map: &MmapMut| bytemuck::cast_slice(&map[range]))
}

/// `len` bytes of fresh zeroed memory.
fn anonymous_map(len: usize) -> MmapMut {
    MmapOptions::new()
        .len(len)
        .map_anon()
        .unwrap_or_else(|_| out_of_memory(len))
}

/// Aborts, as `Vec` does when memory cannot be had.
fn out_of_memory(bytes: usize) -> ! {
    handle_alloc_error(
        Layout::from_size_align(bytes.min(isize::MAX as usize), 1).unwrap_or(Layout::new::<u8>()),
    )
}

/// Pages that `bytes` of values occupy.
fn resident(bytes: usize) -> usize {
    round_up(bytes, if advised(bytes) { HUGE_PAGE } else { PAGE })
}

/// Whether an array of `bytes` goes on huge pages (see [`ADVISE_FROM`]).
fn advised(bytes: usize) -> bool {
    bytes >= ADVISE_FROM
}

fn round_up(bytes: usize, page: usize) -> usize {
    bytes.div_ceil(page) * page
}

/// A hint: where transparent huge pages are off, or the kernel has none
/// to give, the range keeps ordinary pages and nothing else changes.
fn advise_huge_pages(map: &MmapMut, offset: usize, len: usize) {
    #[cfg(target_os = "linux")]
    let _ = map.advise_range(memmap2::Advice::HugePage, offset, len);
    #[cfg(not(target_os = "linux"))]
    let _ = (map, offset, len);
}

impl<T: Pod> Default for HugeArray<T> {
    fn default() -> Self {
        Self::new(0, |_| {})
    }
}

impl<T> Drop for HugeArray<T> {
    fn drop(&mut self) {
        LIVE_BYTES.fetch_sub(self.resident_bytes(), Ordering::Relaxed);
    }
}

impl<T: Pod> Clone for HugeArray<T> {
    fn clone(&self) -> Self {
        Self::from_slice(self)
    }
}

impl<T> std::fmt::Debug for HugeArray<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HugeArray")
            .field("len", &self.len())
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_and_empty_arrays_hold_their_values() {
        let empty: HugeArray<u32> = HugeArray::default();
        assert!(empty.is_empty() && empty[..].is_empty());
        let small = HugeArray::from_slice(&[1u32, 2, 3]);
        assert_eq!(small[..], [1, 2, 3]);
        assert_eq!(small.resident_bytes(), PAGE);
        assert_eq!(small.clone()[..], [1, 2, 3]);
    }

    #[test]
    fn large_arrays_start_on_a_huge_page_and_hold_their_values() {
        let len = ADVISE_FROM / 4 + 1000;
        let a: HugeArray<u32> = HugeArray::new(len, |values| {
            assert!(values.iter().all(|&v| v == 0));
            for (i, v) in values.iter_mut().enumerate() {
                *v = i as u32;
            }
        });
        assert_eq!(a.as_ptr() as usize % HUGE_PAGE, 0);
        let b = a.clone();
        assert_eq!(b.len(), len);
        assert!(b.iter().enumerate().all(|(i, &v)| v == i as u32));
        assert_eq!(b.resident_bytes(), ADVISE_FROM + HUGE_PAGE);
    }
}
