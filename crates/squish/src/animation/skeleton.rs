//! Node hierarchies with rest transforms, and world transforms of a pose.

use glam::DMat4;

use super::{AnimationError, NodeTransform};

/// A node of a skeleton (or of a whole scene graph: joints are just nodes).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SkeletonNode {
    /// Name from the file; may be empty.
    pub name: String,
    /// Parent node, `None` for a root.
    pub parent: Option<usize>,
    /// Local transform when no animation drives the node.
    pub rest: NodeTransform,
}

/// A forest of nodes. Nodes may be listed in any order; [`Skeleton::new`] checks the parent
/// links and computes an order with parents before children once, so that world transforms
/// are a single pass.
///
/// Serialized as its list of nodes; deserialization goes through [`Skeleton::new`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "Vec<SkeletonNode>", into = "Vec<SkeletonNode>")]
pub struct Skeleton {
    nodes: Vec<SkeletonNode>,
    /// Node ids with every parent before its children (roots in id order, then depth-first).
    order: Vec<usize>,
}

impl Skeleton {
    /// Checks that parents are in range and form no cycle.
    pub fn new(nodes: Vec<SkeletonNode>) -> Result<Self, AnimationError> {
        let n = nodes.len();
        for (node, data) in nodes.iter().enumerate() {
            if let Some(parent) = data.parent
                && parent >= n
            {
                return Err(AnimationError::ParentOutOfRange { node, parent, nodes: n });
            }
        }
        let mut children_start = vec![0usize; n + 1];
        for data in &nodes {
            if let Some(p) = data.parent {
                children_start[p + 1] += 1;
            }
        }
        for i in 0..n {
            children_start[i + 1] += children_start[i];
        }
        let mut fill = children_start.clone();
        let mut children = vec![0usize; children_start[n]];
        for (node, data) in nodes.iter().enumerate() {
            if let Some(p) = data.parent {
                children[fill[p]] = node;
                fill[p] += 1;
            }
        }
        let mut order = Vec::with_capacity(n);
        let mut stack = Vec::new();
        for root in (0..n).filter(|&i| nodes[i].parent.is_none()) {
            stack.push(root);
            while let Some(node) = stack.pop() {
                order.push(node);
                // Reverse so that children come out in increasing id order.
                stack.extend(children[children_start[node]..children_start[node + 1]].iter().rev());
            }
        }
        if order.len() != n {
            // Nodes never reached from a root sit on a cycle (or below one).
            let mut reached = vec![false; n];
            for &i in &order {
                reached[i] = true;
            }
            let node = reached.iter().position(|&r| !r).unwrap_or(0);
            return Err(AnimationError::Cycle { node });
        }
        Ok(Self { nodes, order })
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True if there is no node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The nodes, in the order given to [`Skeleton::new`].
    pub fn nodes(&self) -> &[SkeletonNode] {
        &self.nodes
    }

    /// Node ids ordered with parents before children.
    pub fn order(&self) -> &[usize] {
        &self.order
    }

    /// The first node with this name.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    /// The rest local transforms.
    pub fn rest_pose(&self) -> Vec<NodeTransform> {
        self.nodes.iter().map(|n| n.rest).collect()
    }

    /// World transforms `world(parent) · local(node)` of a pose given as local transforms.
    ///
    /// # Panics
    /// If `local` does not have one transform per node (a programming error: poses come from
    /// [`Skeleton::rest_pose`] or [`super::AnimationClip::evaluate`] on this skeleton).
    pub fn world_transforms(&self, local: &[NodeTransform]) -> Vec<DMat4> {
        assert_eq!(local.len(), self.nodes.len(), "one local transform per skeleton node");
        let matrices: Vec<DMat4> = local.iter().map(NodeTransform::matrix).collect();
        self.world_from_local_matrices(&matrices)
    }

    /// As [`Skeleton::world_transforms`], from local matrices.
    ///
    /// # Panics
    /// If `local` does not have one matrix per node.
    pub fn world_from_local_matrices(&self, local: &[DMat4]) -> Vec<DMat4> {
        assert_eq!(local.len(), self.nodes.len(), "one local matrix per skeleton node");
        let mut world = vec![DMat4::IDENTITY; local.len()];
        for &node in &self.order {
            world[node] = match self.nodes[node].parent {
                Some(p) => world[p] * local[node],
                None => local[node],
            };
        }
        world
    }

    /// World transforms of the rest pose.
    pub fn rest_world_transforms(&self) -> Vec<DMat4> {
        self.world_transforms(&self.rest_pose())
    }
}

impl TryFrom<Vec<SkeletonNode>> for Skeleton {
    type Error = AnimationError;
    fn try_from(nodes: Vec<SkeletonNode>) -> Result<Self, Self::Error> {
        Self::new(nodes)
    }
}

impl From<Skeleton> for Vec<SkeletonNode> {
    fn from(skeleton: Skeleton) -> Self {
        skeleton.nodes
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::animation::Trs;
    use glam::DVec3;

    fn node(parent: Option<usize>, x: f64) -> SkeletonNode {
        SkeletonNode {
            name: format!("n{x}"),
            parent,
            rest: NodeTransform::Trs(Trs { translation: DVec3::new(x, 0.0, 0.0), ..Trs::IDENTITY }),
        }
    }

    #[test]
    fn children_listed_before_parents_still_compose() {
        // 0 is a grandchild of 2 via 1; listed child-first.
        let skeleton = Skeleton::new(vec![node(Some(1), 1.0), node(Some(2), 10.0), node(None, 100.0)]).unwrap();
        assert_eq!(skeleton.order(), &[2, 1, 0]);
        let world = skeleton.rest_world_transforms();
        assert_eq!(world[0].transform_point3(DVec3::ZERO), DVec3::new(111.0, 0.0, 0.0));
        assert_eq!(world[1].transform_point3(DVec3::ZERO), DVec3::new(110.0, 0.0, 0.0));
        assert_eq!(skeleton.find("n10"), Some(1));
    }

    #[test]
    fn serde_round_trip_and_validation() {
        let skeleton = Skeleton::new(vec![node(None, 1.0), node(Some(0), 2.0)]).unwrap();
        let json = serde_json::to_string(&skeleton).unwrap();
        assert_eq!(serde_json::from_str::<Skeleton>(&json).unwrap(), skeleton);
        let cyclic = serde_json::to_string(&vec![node(Some(0), 1.0)]).unwrap();
        assert!(serde_json::from_str::<Skeleton>(&cyclic).is_err());
    }

    #[test]
    fn cycles_and_bad_parents_are_errors() {
        let err = Skeleton::new(vec![node(None, 0.0), node(Some(2), 0.0), node(Some(1), 0.0)]).unwrap_err();
        assert_eq!(err, AnimationError::Cycle { node: 1 });
        let err = Skeleton::new(vec![node(Some(5), 0.0)]).unwrap_err();
        assert_eq!(err, AnimationError::ParentOutOfRange { node: 0, parent: 5, nodes: 1 });
        let err = Skeleton::new(vec![node(Some(0), 0.0)]).unwrap_err();
        assert_eq!(err, AnimationError::Cycle { node: 0 });
    }
}
