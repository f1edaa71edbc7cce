//! Statement order: a doubly linked list of item slots, so that statements can
//! be inserted after their parent in O(1) while ids stay stable.
//!
//! Slots are never unlinked: a removed face keeps its slot (skipped on output),
//! so that faces added "after" it land where it was.

use ug::Item;

pub(crate) const NIL: u32 = u32::MAX;

#[derive(Clone, Debug, Default)]
pub(crate) struct Order {
    items: Vec<Item>,
    prev: Vec<u32>,
    next: Vec<u32>,
    /// The last slot inserted directly after each slot (its last "child"), or NIL.
    last_child: Vec<u32>,
    head: u32,
    tail: u32,
}

impl Order {
    /// The items in sequence.
    pub(crate) fn new(items: Vec<Item>) -> Order {
        let n = items.len() as u32;
        let prev = (0..n).map(|i| if i == 0 { NIL } else { i - 1 }).collect();
        let next = (0..n)
            .map(|i| if i + 1 == n { NIL } else { i + 1 })
            .collect();
        Order {
            items,
            prev,
            next,
            last_child: vec![NIL; n as usize],
            head: if n == 0 { NIL } else { 0 },
            tail: if n == 0 { NIL } else { n - 1 },
        }
    }

    pub(crate) fn len(&self) -> usize {
        self.items.len()
    }

    pub(crate) fn item(&self, slot: u32) -> &Item {
        &self.items[slot as usize]
    }

    fn alloc(&mut self, item: Item) -> u32 {
        let s = self.items.len() as u32;
        self.items.push(item);
        self.prev.push(NIL);
        self.next.push(NIL);
        self.last_child.push(NIL);
        s
    }

    /// Links a fresh slot right after `at` (NIL: at the front).
    fn link_after(&mut self, at: u32, item: Item) -> u32 {
        let s = self.alloc(item);
        let nx = if at == NIL {
            self.head
        } else {
            self.next[at as usize]
        };
        self.prev[s as usize] = at;
        self.next[s as usize] = nx;
        if at == NIL {
            self.head = s;
        } else {
            self.next[at as usize] = s;
        }
        if nx == NIL {
            self.tail = s;
        } else {
            self.prev[nx as usize] = s;
        }
        s
    }

    /// Appends at the end.
    pub(crate) fn push_back(&mut self, item: Item) -> u32 {
        let t = self.tail;
        self.link_after(t, item)
    }

    /// Inserts directly after `at` (NIL: at the front), not after its children.
    pub(crate) fn insert_directly_after(&mut self, at: u32, item: Item) -> u32 {
        self.link_after(at, item)
    }

    /// Inserts as the last "child" of `parent`: after `parent` and after
    /// everything inserted after it before (recursively), so that children keep
    /// their creation order and grandchildren follow their own parent.
    pub(crate) fn insert_child(&mut self, parent: u32, item: Item) -> u32 {
        let mut at = parent;
        while self.last_child[at as usize] != NIL {
            at = self.last_child[at as usize];
        }
        let s = self.link_after(at, item);
        self.last_child[parent as usize] = s;
        s
    }

    /// Slots in sequence with their items.
    pub(crate) fn iter(&self) -> OrderIter<'_> {
        OrderIter {
            order: self,
            at: self.head,
        }
    }

    /// Checks the links (for `validate`): every slot reached exactly once, prev/next agree.
    pub(crate) fn check(&self) -> Result<(), String> {
        let mut seen = vec![false; self.items.len()];
        let mut at = self.head;
        let mut prev = NIL;
        let mut count = 0usize;
        while at != NIL {
            let i = at as usize;
            if i >= self.items.len() {
                return Err(format!("order: slot {at} out of range"));
            }
            if seen[i] {
                return Err(format!("order: slot {at} reached twice"));
            }
            seen[i] = true;
            if self.prev[i] != prev {
                return Err(format!("order: slot {at} has a wrong back link"));
            }
            prev = at;
            at = self.next[i];
            count += 1;
        }
        if prev != self.tail {
            return Err("order: tail does not end the list".into());
        }
        if count != self.items.len() {
            return Err(format!(
                "order: {} of {} slots linked",
                count,
                self.items.len()
            ));
        }
        Ok(())
    }
}

pub(crate) struct OrderIter<'a> {
    order: &'a Order,
    at: u32,
}

impl<'a> Iterator for OrderIter<'a> {
    type Item = (u32, &'a Item);
    fn next(&mut self) -> Option<Self::Item> {
        if self.at == NIL {
            return None;
        }
        let s = self.at;
        self.at = self.order.next[s as usize];
        Some((s, &self.order.items[s as usize]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(s: &str) -> Item {
        Item::Comment(s.into())
    }

    fn texts(o: &Order) -> Vec<String> {
        o.iter()
            .map(|(_, it)| match it {
                Item::Comment(s) => s.clone(),
                _ => unreachable!(),
            })
            .collect()
    }

    #[test]
    fn children_keep_creation_order_and_nest() {
        let mut o = Order::new(vec![c("a"), c("b"), c("z")]);
        let b = 1;
        let b1 = o.insert_child(b, c("b1"));
        o.insert_child(b, c("b2"));
        o.insert_child(b1, c("b1x"));
        o.insert_child(b, c("b3"));
        o.push_back(c("end"));
        o.insert_directly_after(NIL, c("front"));
        assert_eq!(
            texts(&o),
            ["front", "a", "b", "b1", "b1x", "b2", "b3", "z", "end"]
        );
        o.check().unwrap();
        assert_eq!(o.len(), 9);
    }

    #[test]
    fn empty_list() {
        let mut o = Order::new(vec![]);
        assert_eq!(o.iter().count(), 0);
        o.check().unwrap();
        o.push_back(c("x"));
        o.insert_directly_after(0, c("y"));
        assert_eq!(texts(&o), ["x", "y"]);
        o.check().unwrap();
    }
}
