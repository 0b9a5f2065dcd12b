//! A pose: the animatable state of every node of one asset.

use crate::asset::Asset;
use crate::math::Transform;

/// Node-local transforms and flat morph weights of one asset.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pose {
    /// Local transform by node index.
    pub locals: Vec<Transform>,
    /// Morph weights of all nodes, flat; node `n` owns
    /// `asset.weight_offsets[n]..asset.weight_offsets[n] + asset.nodes[n].weights.len()`.
    pub weights: Vec<f32>,
}

impl Pose {
    /// The rest pose of `asset`: every node's file transform and default morph weights.
    pub fn rest(asset: &Asset) -> Pose {
        let mut pose = Pose::default();
        pose.reset_to_rest(asset);
        pose
    }

    /// Overwrites this pose with the rest pose of `asset`. Allocates only when the pose
    /// was built for a smaller asset.
    pub fn reset_to_rest(&mut self, asset: &Asset) {
        self.locals.clear();
        self.locals.extend(asset.nodes.iter().map(|n| n.rest));
        self.weights.clear();
        self.weights.resize(asset.weight_total as usize, 0.0);
        for (node, &offset) in asset.nodes.iter().zip(&asset.weight_offsets) {
            let start = offset as usize;
            if let Some(dst) = self.weights.get_mut(start..start + node.weights.len()) {
                dst.copy_from_slice(&node.weights);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::asset::Node;
    use crate::math::Vec3;

    #[test]
    fn rest_pose_copies_transforms_and_weights() {
        let rest = Transform { translation: Vec3::X, ..Transform::IDENTITY };
        let asset = Asset {
            nodes: vec![
                Node { rest, weights: vec![0.25, 0.5], ..Node::default() },
                Node::default(),
                Node { weights: vec![1.0], ..Node::default() },
            ],
            order: vec![0, 1, 2],
            weight_offsets: vec![0, 2, 2],
            weight_total: 3,
            extensions: Default::default(),
            ..Asset::default()
        };
        let mut pose = Pose::rest(&asset);
        assert_eq!(pose.locals[0], rest);
        assert_eq!(pose.weights, vec![0.25, 0.5, 1.0]);
        pose.weights[0] = 9.0;
        pose.locals[1].translation = Vec3::Y;
        pose.reset_to_rest(&asset);
        assert_eq!(pose, Pose::rest(&asset));
    }
}
