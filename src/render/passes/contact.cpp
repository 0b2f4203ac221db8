// Contact shadows toward the primary light (the sun, else the first spot, else the first point
// light): ContactShadowPass (depth resolve + march) over the prepass's
// depth and normals, into the contact mask. A shader edit gives the pass new pipelines; its mask
// stays the same image, so the passes that sample it keep their descriptor sets.

#include "passes.hpp"

namespace penumbra::render::passes {

ContactPass::ContactPass(FrameResources& r) {
  ContactShadowPassDesc desc;
  desc.width = r.width;
  desc.height = r.height;
  desc.settings = r.scene.contact;
  desc.shader_dir = r.registry.shader_dir();
  r.add_prepared_pipeline(
      "contact-shadows (depth resolve + march)",
      {{"contact_shadows.comp", {}}, {"depth_resolve.comp", {}}},
      [this, &r, desc](const shader::Spirvs& spirv) -> shader::ProgramRegistry::Install {
        if (pass_) {
          auto prepared = pass_->prepare_spirv(spirv[0], spirv[1]);
          return [this, prepared] { pass_->install(prepared); };
        }
        ContactShadowPassDesc d = desc;  // the first build: the pass and its images
        d.march_spirv = spirv[0];
        d.resolve_spirv = spirv[1];
        return [this, &r, d] {
          pass_ = std::make_unique<ContactShadowPass>(r.ctx, d);
          r.contact_mask = pass_->mask();
        };
      });
  r.report.passes.push_back("contact-shadows: compute (" +
                            std::to_string(desc.settings.step_count) + " steps)");
  r.report.images.push_back("contact-mask " + std::to_string(r.width) + "x" +
                            std::to_string(r.height) + " R8 + resolved depth R32F");
}

std::vector<Step> ContactPass::steps(FrameResources& r) {
  Step resolve{"contact-resolve",
               {{"depth", &r.depth, Use::sampled},
                {"contact-resolved-depth", pass_->resolved_depth(), Use::storage_write}},
               [this, &r](VkCommandBuffer cmd) { pass_->record_resolve(cmd, r.depth, r.normal); },
               {}};
  Step march{
      "contact-shadows",
      {{"contact-resolved-depth", pass_->resolved_depth(), Use::sampled},
       {"depth", &r.depth, Use::sampled},
       {"normal", &r.normal, Use::sampled},
       {"contact-mask", pass_->mask(), Use::storage_write}},
      [this, &r](VkCommandBuffer cmd) { pass_->record_march(cmd, r.depth, r.normal, frame(r)); },
      "contact-shadows"};
  return {resolve, march};
}

ContactShadowFrame ContactPass::frame(const FrameResources& r) const {
  ContactShadowFrame f;
  const auto cam = frame_camera(r.scene, r.width, r.height, r.packed.frame.mode.x);
  f.camera = ContactCamera::from(
      cam, r.reverse_z ? shadow::DepthConvention::reverse_z : shadow::DepthConvention::standard);
  // The primary light (primary_light_slot): the sun's direction, or a spot or point light's
  // position relative to the camera.
  const int slot = primary_light_slot(r.scene);
  if (slot == 0) {
    f.light_dir_view = to_contact_view(cam, -glm::dvec3(r.scene.sun->direction));
  } else {
    const glm::vec3 p = slot == 1 ? r.scene.spots[0].position : r.scene.points[0].position;
    f.light_position_view = to_contact_view(cam, glm::dvec3(p) - cam.position);
  }
  f.frame = r.packed.frame.mode.x;
  f.caster_mask = true;  // the prepass marks casters in the normals' alpha
  return f;
}

}  // namespace penumbra::render::passes
