//! A rank's restart state as named sections of plain data (`bytemuck::Pod` arrays), written to
//! and read from one file per rank (`driver::checkpoint`). Each stage puts its arrays under its
//! own prefix (`fe.`, `sph.`, `contact.`).
use bytemuck::Pod;
use std::collections::BTreeMap;

/// Sections being written.
#[derive(Default)]
pub struct StateWriter {
    buf: Vec<u8>,
}

impl StateWriter {
    /// Adds the array `data` under `name`.
    pub fn put<T: Pod>(&mut self, name: &str, data: &[T]) {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        self.buf
            .extend_from_slice(&(name.len() as u32).to_le_bytes());
        self.buf.extend_from_slice(name.as_bytes());
        self.buf
            .extend_from_slice(&(bytes.len() as u64).to_le_bytes());
        self.buf.extend_from_slice(bytes);
    }

    /// The bytes of the file.
    pub fn into_bytes(self) -> Vec<u8> {
        self.buf
    }
}

/// Sections read back.
pub struct StateReader {
    sections: BTreeMap<String, Vec<u8>>,
}

impl StateReader {
    /// Parses a file's bytes; an error names what is wrong.
    pub fn parse(mut b: &[u8]) -> Result<StateReader, String> {
        let mut sections = BTreeMap::new();
        let take = |b: &mut &[u8], n: usize| -> Result<Vec<u8>, String> {
            if b.len() < n {
                return Err("truncated checkpoint".into());
            }
            let (h, t) = b.split_at(n);
            *b = t;
            Ok(h.to_vec())
        };
        while !b.is_empty() {
            let n = u32::from_le_bytes(take(&mut b, 4)?.try_into().expect("4 bytes")) as usize;
            let name = String::from_utf8(take(&mut b, n)?).map_err(|_| "bad section name")?;
            let len = u64::from_le_bytes(take(&mut b, 8)?.try_into().expect("8 bytes")) as usize;
            sections.insert(name, take(&mut b, len)?);
        }
        Ok(StateReader { sections })
    }

    /// The array under `name` (copied: the file's bytes need not be aligned for `T`).
    pub fn get<T: Pod>(&self, name: &str) -> Result<Vec<T>, String> {
        let b = self
            .sections
            .get(name)
            .ok_or_else(|| format!("checkpoint: {name}: missing"))?;
        let size = std::mem::size_of::<T>().max(1);
        if b.len() % size != 0 {
            return Err(format!("checkpoint: {name}: {} bytes", b.len()));
        }
        let mut v = vec![T::zeroed(); b.len() / size];
        bytemuck::cast_slice_mut::<T, u8>(&mut v).copy_from_slice(b);
        Ok(v)
    }

    /// Whether `name` is present.
    pub fn has(&self, name: &str) -> bool {
        self.sections.contains_key(name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_come_back_bit_for_bit() {
        let mut w = StateWriter::default();
        let a = [1.0f64, -0.0, f64::MIN_POSITIVE, 1e300];
        let b = [3u64, u64::MAX];
        w.put("a", &a);
        w.put("b.c", &b);
        w.put::<u8>("empty", &[]);
        let r = StateReader::parse(&w.into_bytes()).unwrap();
        let a2: Vec<f64> = r.get("a").unwrap();
        assert!(a.iter().zip(&a2).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert_eq!(r.get::<u64>("b.c").unwrap(), b);
        assert!(r.get::<u8>("empty").unwrap().is_empty());
        assert!(r.get::<f64>("nope").unwrap_err().contains("missing"));
        assert!(StateReader::parse(&[1, 0, 0]).is_err());
    }
}
