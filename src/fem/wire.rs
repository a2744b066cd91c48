//! Plain data as little-endian bytes, for what one rank builds and sends the others: the parsed
//! Gmsh file ([`super::gmsh::GmshMesh::to_bytes`]), a body's problem and its part of the mesh
//! (`problem::BodyProblem::to_bytes`), a rank's partition. A [`Reader`] refuses bytes that end
//! early, and a count the remaining bytes cannot hold before allocating for it.

/// Appends values to a byte buffer.
#[derive(Debug, Default)]
pub struct Writer(pub Vec<u8>);

impl Writer {
    pub fn with_capacity(n: usize) -> Writer {
        Writer(Vec::with_capacity(n))
    }

    /// A count or an index.
    pub fn int(&mut self, v: usize) {
        self.0.extend_from_slice(&(v as u64).to_le_bytes());
    }

    pub fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    pub fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    pub fn i32(&mut self, v: i32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    pub fn u8(&mut self, v: u8) {
        self.0.push(v);
    }

    pub fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    pub fn text(&mut self, t: &str) {
        self.bytes(t.as_bytes());
    }

    /// Bytes, after their length.
    pub fn bytes(&mut self, b: &[u8]) {
        self.int(b.len());
        self.0.extend_from_slice(b);
    }

    /// A list: its length, then each entry by `each`.
    pub fn list<T>(&mut self, items: &[T], mut each: impl FnMut(&mut Writer, &T)) {
        self.int(items.len());
        for x in items {
            each(self, x);
        }
    }

    pub fn ints(&mut self, v: &[usize]) {
        self.list(v, |w, &x| w.int(x));
    }

    pub fn u32s(&mut self, v: &[u32]) {
        self.list(v, |w, &x| w.u32(x));
    }

    pub fn f64s(&mut self, v: &[f64]) {
        self.list(v, |w, &x| w.f64(x));
    }

    pub fn points(&mut self, v: &[[f64; 2]]) {
        self.list(v, |w, p| {
            w.f64(p[0]);
            w.f64(p[1]);
        });
    }
}

/// Reads what a [`Writer`] wrote, in the same order; `None` where the bytes end early or do
/// not hold what is asked.
#[derive(Debug)]
pub struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Reader<'a> {
        Reader { bytes, at: 0 }
    }

    /// Whether every byte was read.
    pub fn is_done(&self) -> bool {
        self.at == self.bytes.len()
    }

    /// The bytes not read yet (all of them are then read).
    pub fn rest(&mut self) -> &'a [u8] {
        let rest = &self.bytes[self.at..];
        self.at = self.bytes.len();
        rest
    }

    pub fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let b = self.bytes.get(self.at..self.at.checked_add(N)?)?;
        self.at += N;
        b.try_into().ok()
    }

    pub fn int(&mut self) -> Option<usize> {
        usize::try_from(u64::from_le_bytes(self.take()?)).ok()
    }

    pub fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take()?))
    }

    pub fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take()?))
    }

    pub fn i32(&mut self) -> Option<i32> {
        Some(i32::from_le_bytes(self.take()?))
    }

    pub fn u8(&mut self) -> Option<u8> {
        Some(self.take::<1>()?[0])
    }

    pub fn f64(&mut self) -> Option<f64> {
        Some(f64::from_le_bytes(self.take()?))
    }

    pub fn text(&mut self) -> Option<String> {
        String::from_utf8(self.bytes()?.to_vec()).ok()
    }

    /// What [`Writer::bytes`] wrote.
    pub fn bytes(&mut self) -> Option<&'a [u8]> {
        let n = self.int()?;
        let b = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(b)
    }

    /// A count of entries of at least `entry` bytes each, refused where the remaining bytes
    /// cannot hold them (before anything is allocated for them).
    pub fn count(&mut self, entry: usize) -> Option<usize> {
        let n = self.int()?;
        (n <= (self.bytes.len() - self.at) / entry.max(1)).then_some(n)
    }

    /// A list [`Writer::list`] wrote, each entry of at least `entry` bytes read by `each`.
    pub fn list<T>(
        &mut self,
        entry: usize,
        mut each: impl FnMut(&mut Reader<'a>) -> Option<T>,
    ) -> Option<Vec<T>> {
        let n = self.count(entry)?;
        (0..n).map(|_| each(self)).collect()
    }

    pub fn ints(&mut self) -> Option<Vec<usize>> {
        self.list(8, Reader::int)
    }

    pub fn u32s(&mut self) -> Option<Vec<u32>> {
        self.list(4, Reader::u32)
    }

    pub fn f64s(&mut self) -> Option<Vec<f64>> {
        self.list(8, Reader::f64)
    }

    pub fn points(&mut self) -> Option<Vec<[f64; 2]>> {
        self.list(16, |r| Some([r.f64()?, r.f64()?]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_a_writer_wrote_reads_back_and_short_bytes_are_refused() {
        let mut w = Writer::default();
        w.int(7);
        w.text("body1");
        w.points(&[[1.5, -2.0], [0.0, f64::MIN_POSITIVE]]);
        w.u32s(&[3, 1, 4]);
        w.i32(-5);
        w.u8(9);
        let bytes = w.0;
        let mut r = Reader::new(&bytes);
        assert_eq!(r.int(), Some(7));
        assert_eq!(r.text().as_deref(), Some("body1"));
        assert_eq!(
            r.points(),
            Some(vec![[1.5, -2.0], [0.0, f64::MIN_POSITIVE]])
        );
        assert_eq!(r.u32s(), Some(vec![3, 1, 4]));
        assert_eq!((r.i32(), r.u8()), (Some(-5), Some(9)));
        assert!(r.is_done());
        // Every truncation fails somewhere instead of reading past the end.
        for cut in 0..bytes.len() {
            let mut r = Reader::new(&bytes[..cut]);
            let read = (|| {
                r.int()?;
                r.text()?;
                r.points()?;
                r.u32s()?;
                r.i32()?;
                r.u8()
            })();
            assert_eq!(read, None, "cut at {cut}");
        }
        // A count larger than the bytes left is refused before allocating.
        let mut w = Writer::default();
        w.int(usize::MAX / 2);
        assert_eq!(Reader::new(&w.0).f64s(), None);
    }
}
