//! Applying the commands of the page, the panels and the keyboard to the viewer.

use super::*;

/// A thrown ball's radius, as a fraction of the model's size.
#[cfg(feature = "full")]
const BALL_RADIUS: f32 = 0.05;

impl Stage {
    /// Applies one command to the shown model (the side panel's actions go through here too).
    pub(crate) fn apply(&mut self, command: Command) -> Result<(), String> {
        match command {
            Command::SetSkinning(method) => {
                self.skinning = method;
                if let Some(model) = &mut self.model {
                    model.instance.set_skinning(&model.asset, method);
                    model.sync_copies();
                }
                return Ok(());
            }
            Command::SetSkinningPath(path) => {
                return self.scene.set_skinning_path(path);
            }
            Command::SetHeatmap(on) => {
                self.scene.set_heatmap(on);
                return Ok(());
            }
            Command::SetPanels(on) => {
                self.panels = on;
                return Ok(());
            }
            Command::SetTransitionDuration(seconds) => {
                self.transition.duration = seconds.max(0.0);
                return Ok(());
            }
            Command::SetTransition { easing, outgoing } => {
                self.transition.easing = easing.unwrap_or(self.transition.easing);
                self.transition.outgoing = outgoing.unwrap_or(self.transition.outgoing);
                return Ok(());
            }
            Command::SetDropHint(on) => {
                self.drop_hint = on;
                return Ok(());
            }
            Command::SetGrid(on) => {
                self.scene.set_grid(on);
                return Ok(());
            }
            Command::SetCameraLimits { limits, fov } => {
                self.camera.limits = limits.sanitized();
                self.camera.fov_y = fov.filter(|f| f.is_finite()).unwrap_or(45f32.to_radians());
                self.camera.constrain();
                return Ok(());
            }
            Command::SetOverlays(overlays) => {
                self.overlays = overlays;
                return Ok(());
            }
            Command::Screenshot => {
                self.screenshot();
                return Ok(());
            }
            Command::SetLighting(lighting) => {
                self.scene.set_look(crate::render::uniforms::Look { lighting, ..self.scene.look() });
                return Ok(());
            }
            Command::SetBackground(background) => {
                self.scene.set_look(crate::render::uniforms::Look { background, ..self.scene.look() });
                return Ok(());
            }
            Command::SetExposure(exposure) => {
                let exposure =
                    if exposure.is_finite() { exposure.clamp(0.0, crate::render::uniforms::MAX_EXPOSURE) } else { 1.0 };
                self.scene.set_look(crate::render::uniforms::Look { exposure, ..self.scene.look() });
                self.exposure_text = exposure_name(exposure);
                return Ok(());
            }
            Command::SetToneMapping(tone_mapping) => {
                self.scene.set_look(crate::render::uniforms::Look { tone_mapping, ..self.scene.look() });
                return Ok(());
            }
            Command::SetEnvironment(environment, image) => {
                if image.is_some() {
                    self.scene.set_environment_image(image);
                }
                self.environment_wanted = None;
                // A photograph is fetched on first use: the light changes when it is in.
                if let crate::render::uniforms::EnvironmentChoice::Named(name) = environment
                    && let crate::render::environment::Builtin::Photo(photo) = name.builtin()
                {
                    match crate::photos::request(photo, self.controls.waker()) {
                        Ok(true) => {}
                        Ok(false) => {
                            self.environment_wanted = Some(name);
                            return Ok(());
                        }
                        Err(message) => {
                            self.environment_failed(name, &message);
                            return Ok(());
                        }
                    }
                }
                self.scene.set_look(crate::render::uniforms::Look { environment, ..self.scene.look() });
                return Ok(());
            }
            Command::SetShadow(intensity, softness) => {
                let unit = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
                let (shadow_intensity, shadow_softness) = (unit(intensity), unit(softness));
                self.scene.set_look(crate::render::uniforms::Look {
                    shadow_intensity,
                    shadow_softness,
                    ..self.scene.look()
                });
                self.shadow_text = shadow_name(shadow_intensity, shadow_softness);
                return Ok(());
            }
            Command::DropPendingEnvironment => {
                self.environment_wanted = None;
                return Ok(());
            }
            Command::SetEnvironmentRotation(angle) => {
                let environment_rotation =
                    if angle.is_finite() { angle.rem_euclid(std::f32::consts::TAU) } else { 0.0 };
                self.scene.set_look(crate::render::uniforms::Look { environment_rotation, ..self.scene.look() });
                return Ok(());
            }
            Command::SetSamples(samples) => {
                self.samples = samples;
                return Ok(());
            }
            Command::LoadUrl(url) => {
                self.pending += 1;
                self.status = Status::Loading;
                if let Some(wake) = self.controls.waker() {
                    load::fetch_into(url, self.inbox.clone(), wake);
                }
                return Ok(());
            }
            Command::ShowModel(i) => {
                let Some(library) = &self.library else { return Ok(()) };
                let Some(name) = library.models.get(i) else { return Ok(()) };
                let loaded = load::import_model(&library.files, Some(name))?;
                self.install(loaded, None)?;
                if let Some(library) = &mut self.library {
                    library.shown = Some(i);
                }
                return Ok(());
            }
            Command::LoadSample(Sample::CandyWrapper) => {
                let panel = CandyPanel::new();
                let loaded = panel.model();
                self.install(loaded, Some(panel))?;
                self.status = Status::Ready;
                self.last_error.clear();
                self.error_window = None;
                return Ok(());
            }
            #[cfg(feature = "full")]
            Command::FinishSculpt => {
                let Some(model) = &mut self.model else { return Ok(()) };
                let next = model.finish_sculpt()?;
                return self.set_examples(next);
            }
            #[cfg(feature = "full")]
            Command::DeleteExample(i) => {
                let Some(model) = &mut self.model else { return Ok(()) };
                if model.sculpt.is_some() {
                    return Err("finish or cancel the example pose being sculpted first".into());
                }
                let next = model.without_example(i)?;
                return self.set_examples(next);
            }
            #[cfg(feature = "full")]
            Command::AddExamplePose(joint) => {
                let previous = self.skinning;
                let Some(model) = &mut self.model else { return Ok(()) };
                model.start_sculpt(joint, previous)?;
                // The sculpt is shown under SJB by example: the menus, copies and data-skinning say so.
                return self.apply(Command::SetSkinning(SkinningMethod::SphericalJointBlendByExample));
            }
            #[cfg(feature = "full")]
            Command::CancelSculpt => {
                let Some(state) = self.model.as_mut().and_then(|m| m.sculpt.take()) else { return Ok(()) };
                return self.apply(Command::SetSkinning(state.previous));
            }
            _ => {}
        }
        let Some(model) = &mut self.model else { return Ok(()) };
        // Copies replay the main animator: only commands that change it need a re-sync.
        let animates = matches!(
            command,
            Command::Play
                | Command::Pause
                | Command::PlayClip(_)
                | Command::CrossfadeTo { .. }
                | Command::Seek(_)
                | Command::SetSpeed(_)
                | Command::SetLoop(_)
                | Command::SetLayer { .. }
                | Command::SetBlend(_)
                | Command::SetCandyPose { .. }
        );
        match command {
            Command::SetSkinning(_)
            | Command::SetSkinningPath(_)
            | Command::SetHeatmap(_)
            | Command::LoadSample(_)
            | Command::SetPanels(_)
            | Command::SetTransitionDuration(_)
            | Command::SetTransition { .. }
            | Command::SetDropHint(_)
            | Command::LoadUrl(_)
            | Command::SetSamples(_)
            | Command::SetGrid(_)
            | Command::SetCameraLimits { .. }
            | Command::SetOverlays(_)
            | Command::Screenshot
            | Command::SetLighting(_)
            | Command::SetBackground(_)
            | Command::SetExposure(_)
            | Command::SetToneMapping(_)
            | Command::SetEnvironment(..)
            | Command::DropPendingEnvironment
            | Command::SetEnvironmentRotation(_)
            | Command::SetShadow(..)
            | Command::ShowModel(_) => {}
            #[cfg(feature = "full")]
            Command::FinishSculpt | Command::DeleteExample(_) | Command::AddExamplePose(_) | Command::CancelSculpt => {}
            #[cfg(feature = "full")]
            Command::SetPoseMode(on) => model.set_pose_mode(on),
            #[cfg(feature = "full")]
            Command::SetPoseWithinLimits(on) => model.pose_within_limits = on,
            #[cfg(feature = "full")]
            Command::SetBrush { brush, radius, strength } => {
                if let Some(state) = &mut model.sculpt {
                    state.brush = brush;
                    state.radius = if radius.is_finite() { radius.clamp(0.005, 0.5) } else { state.radius };
                    state.strength = if strength.is_finite() { strength.clamp(0.0, 1.0) } else { state.strength };
                }
            }

            Command::SelectJoint(node) => model.selected_joint = node,
            #[cfg(feature = "full")]
            Command::SetValidation(validation) => {
                if validation.name == model.name {
                    model.validating = false;
                    model.validation = Some(validation);
                }
            }
            #[cfg(feature = "full")]
            Command::StartRagdoll => model.start_ragdoll()?,
            #[cfg(feature = "full")]
            Command::SetObstacles(list) => model.set_obstacles(list)?,
            #[cfg(feature = "full")]
            Command::ThrowBall { from, velocity } => {
                let size = model.size();
                if let Some(state) = &mut model.ragdoll {
                    state.ragdoll.throw_ball(Vec3::from(from), Vec3::from(velocity), BALL_RADIUS * size);
                }
            }
            #[cfg(feature = "full")]
            Command::SetRagdollStrength(strength) => {
                let strength = if strength.is_finite() { strength.clamp(0.0, 1.0) } else { 0.0 };
                model.ragdoll_options.strength = strength;
                let options = model.ragdoll_options;
                if let Some(state) = &mut model.ragdoll {
                    state.ragdoll.set_options(options);
                }
            }
            #[cfg(feature = "full")]
            Command::StopRagdoll => model.ragdoll = None,
            #[cfg(feature = "full")]
            Command::RagdollToAnimation(seconds) => {
                if let Some(ragdoll) = &mut model.ragdoll {
                    ragdoll.blend_back = Some((0.0, seconds.max(0.0)));
                }
            }
            #[cfg(feature = "full")]
            Command::SetRagdollOptions { gravity, damping } => {
                model.ragdoll_options.gravity = gravity;
                model.ragdoll_options.damping = damping;
                let options = model.ragdoll_options;
                if let Some(ragdoll) = &mut model.ragdoll {
                    ragdoll.ragdoll.set_options(options);
                }
            }
            // The light widget build has no physics: the element loads the full app first.
            #[cfg(not(feature = "full"))]
            Command::StartRagdoll
            | Command::StopRagdoll
            | Command::RagdollToAnimation(_)
            | Command::SetRagdollOptions { .. }
            | Command::SetRagdollStrength(_) => return Err("the ragdoll needs the full app".into()),
            Command::SetJointRotation { node, rotation } => {
                let slot = model
                    .rotation_overrides
                    .get_mut(node as usize)
                    .ok_or_else(|| format!("node {node} does not exist"))?;
                *slot = rotation.map(|[x, y, z, w]| glam::Quat::from_xyzw(x, y, z, w).normalize());
                // Posing within limits: the nearest rotation the joint's IK limit allows.
                #[cfg(feature = "full")]
                if model.pose_within_limits
                    && let (Some(q), Some(limit), Some(n)) = (
                        slot.as_mut(),
                        model.joint_settings.limits.get(node as usize),
                        model.asset.nodes.get(node as usize),
                    )
                {
                    *q = limit.clamp(n.rest.rotation, *q).normalize();
                }
            }
            Command::ResetPose => model.rotation_overrides.fill(None),
            Command::SetExampleSigma { node, sigma } => model.set_example_sigma(node, sigma)?,
            Command::SetMorph { node, target, weight } => {
                let n = model.asset.nodes.get(node as usize).ok_or_else(|| format!("node {node} does not exist"))?;
                if target >= n.weights.len() {
                    return Err(format!(
                        "{}: morph target {target} of {} does not exist",
                        model.name,
                        model.node_name(node)
                    ));
                }
                let start = model.asset.weight_offsets.get(node as usize).copied().unwrap_or(0) as usize;
                if let Some(slot) = model.morph_overrides.get_mut(start + target) {
                    *slot = weight.map(|w| if w.is_finite() { w } else { 0.0 });
                }
            }
            Command::SetCamera([yaw, pitch, distance, x, y, z]) => {
                self.camera.yaw = yaw;
                self.camera.pitch = pitch;
                self.camera.distance = distance;
                self.camera.target = Vec3::new(x, y, z);
                self.camera.orbit(0.0, 0.0);
            }
            Command::SetIk { effector, depth, target } => match effector {
                Some(effector) => {
                    let existing = model.ik.iter().position(|g| g.effector() == effector);
                    let like = existing.or(model.ik.len().checked_sub(1)).and_then(|i| model.ik.get(i));
                    let state = model.ik_goal(effector, depth, target.map(Vec3::from), like)?;
                    match existing {
                        Some(i) => {
                            model.ik[i] = state;
                            model.ik_selected = i;
                        }
                        None => {
                            model.ik.push(state);
                            model.ik_selected = model.ik.len() - 1;
                        }
                    }
                }
                None => {
                    model.ik.clear();
                    model.ik_selected = 0;
                }
            },
            Command::SetIkSolver { effector, solver, pole, softness, accelerate, iterations } => {
                let name = model.node_name(effector);
                let ik = model
                    .ik
                    .iter_mut()
                    .find(|g| g.effector() == effector)
                    .ok_or_else(|| format!("no IK goal on {name}: set its target first"))?;
                if solver == kloub_core::job::ik::IkSolver::TwoBone && ik.depth() != 2 {
                    return Err(format!("two-bone needs 2 joints above {name}, not {}", ik.depth()));
                }
                ik.solver = solver;
                ik.pole = pole.map(Vec3::from);
                ik.softness = softness.unwrap_or(ik.softness);
                ik.accelerate = accelerate.unwrap_or(ik.accelerate);
                ik.iterations = iterations.unwrap_or(ik.iterations);
            }
            Command::ReplaceIk { goal, effector, depth } => {
                if let Some(old) = model.ik.get(goal) {
                    let state = model.ik_goal(effector, depth, Some(old.target), Some(old))?;
                    model.ik[goal] = state;
                    model.ik_selected = goal;
                }
            }
            Command::RemoveIk(goal) => {
                if goal < model.ik.len() {
                    model.ik.remove(goal);
                    model.ik_selected = model.ik_selected.min(model.ik.len().saturating_sub(1));
                }
            }
            Command::SetCopies(n) => {
                model.set_copies(n);
                if let Some((min, max)) = model.grid_bounds() {
                    self.camera.frame_to_fit_aspect(min, max, view_aspect(self.view_rect));
                }
            }
            Command::SetCandyPose { twist, bend } => {
                if let Some(candy) = &mut model.candy {
                    candy.twist = twist.clamp(-360.0, 360.0);
                    candy.bend = bend.clamp(-180.0, 180.0);
                    candy.manual = true;
                    model.set_playing(false);
                }
            }
            Command::Play => model.set_playing(true),
            Command::Pause => model.set_playing(false),
            Command::PlayClip(clip) => model.play_clip(clip, self.transition)?,
            Command::CrossfadeTo { clip, seconds } => {
                model.play_clip(clip, Crossfade { duration: seconds, ..self.transition })?;
            }
            Command::Seek(t) => model.seek(t),
            Command::SetSpeed(speed) => model.set_speed(speed),
            Command::SetLoop(mode) => model.set_loop_mode(mode),
            Command::SetLayer { clip, root, weight } => {
                match clip {
                    Some(clip) => {
                        model.layer.enabled = true;
                        model.layer.clip = clip;
                        model.layer.root = root;
                        model.layer.weight = weight;
                    }
                    None => model.layer.enabled = false,
                }
                model.sync_layer()?;
            }
            Command::SetBlend(weights) => {
                model.blend_weights.iter_mut().for_each(|w| *w = 0.0);
                for (clip, weight) in weights {
                    if let Some(w) = model.blend_weights.get_mut(clip) {
                        *w = weight;
                    }
                }
                model.apply_blend()?;
            }
        }
        if animates && !model.copies.is_empty() {
            model.sync_copies();
        }
        Ok(())
    }
}
