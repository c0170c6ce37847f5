/* Shader modules and pipelines: the raster (ray events), resolve and composite passes. */
#include "renderer_internal.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const uint32_t composite_spv[] = {
#include "composite_comp.inc"
};
static const uint32_t resolve_spv[] = {
#include "resolve_comp.inc"
};
static const uint32_t rects_spv[] = {
#include "rects_comp.inc"
};
static const uint32_t events_vert_spv[] = {
#include "events_vert.inc"
};
static const uint32_t events_frag_spv[] = {
#include "events_frag.inc"
};

/* *out stays VK_NULL_HANDLE on failure; the VkResult goes into the caller's message. */
static VkResult make_module(VkDevice dev, const uint32_t *code, size_t bytes, VkShaderModule *out)
{
    VkShaderModuleCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
        .codeSize = bytes,
        .pCode = code,
    };
    VkResult vr = vkCreateShaderModule(dev, &ci, NULL, out);
    if (vr != VK_SUCCESS) *out = VK_NULL_HANDLE;
    return vr;
}

/* The ray-event pass's two pipelines (events.vert: the footprints rects.comp lists, as
 * rectangles of two triangles and as points), no attachments: fragments only append to
 * storage buffers. */
static leap_result create_events_pipeline(leap_renderer *r, leap_error *err)
{
    VkDevice dev = r->gpu->device;
    VkSubpassDescription subpass = {.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS};
    VkRenderPassCreateInfo rpci = {
        .sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO,
        .subpassCount = 1,
        .pSubpasses = &subpass,
    };
    LEAP_VK_CHECK(vkCreateRenderPass(dev, &rpci, NULL, &r->render_pass));
    VkShaderModule vs = VK_NULL_HANDLE, fs = VK_NULL_HANDLE;
    VkResult vr = make_module(dev, events_vert_spv, sizeof events_vert_spv, &vs);
    if (vr == VK_SUCCESS) vr = make_module(dev, events_frag_spv, sizeof events_frag_spv, &fs);
    VkBool32 points = VK_FALSE; /* constant_id 8 of events.vert */
    const VkSpecializationMapEntry points_entry = {8, 0, sizeof points};
    const VkSpecializationInfo points_spec = {1, &points_entry, sizeof points, &points};
    VkPipelineShaderStageCreateInfo stages[2] = {
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, .stage = VK_SHADER_STAGE_VERTEX_BIT,
         .module = vs, .pName = "main", .pSpecializationInfo = &points_spec},
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, .stage = VK_SHADER_STAGE_FRAGMENT_BIT,
         .module = fs, .pName = "main"},
    };
    VkPipelineVertexInputStateCreateInfo vertex_input = {.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    VkPipelineInputAssemblyStateCreateInfo assembly = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO,
        .topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST,
    };
    VkPipelineViewportStateCreateInfo viewport = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO,
        .viewportCount = 1,
        .scissorCount = 1,
    };
    VkPipelineRasterizationStateCreateInfo raster = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO,
        .depthClampEnable = VK_TRUE, /* faces nearer than the near plane must not be clipped */
        .polygonMode = VK_POLYGON_MODE_FILL,
        .cullMode = VK_CULL_MODE_NONE,
        .frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE,
        .lineWidth = 1.0f,
    };
    VkPipelineMultisampleStateCreateInfo multisample = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO,
        .rasterizationSamples = VK_SAMPLE_COUNT_1_BIT,
    };
    VkPipelineColorBlendStateCreateInfo blend = {.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
    VkDynamicState dyn[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO,
        .dynamicStateCount = 2,
        .pDynamicStates = dyn,
    };
    VkGraphicsPipelineCreateInfo gpci = {
        .sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO,
        .stageCount = 2,
        .pStages = stages,
        .pVertexInputState = &vertex_input,
        .pInputAssemblyState = &assembly,
        .pViewportState = &viewport,
        .pRasterizationState = &raster,
        .pMultisampleState = &multisample,
        .pColorBlendState = &blend,
        .pDynamicState = &dynamic,
        .layout = r->pipeline_layout,
        .renderPass = r->render_pass,
    };
    for (int i = 0; i < 2 && vr == VK_SUCCESS; ++i) {
        points = i == 1;
        assembly.topology = points ? VK_PRIMITIVE_TOPOLOGY_POINT_LIST : VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
        vr = vkCreateGraphicsPipelines(dev, r->gpu->pipeline_cache, 1, &gpci, NULL, &r->events[i]);
    }
    if (vs) vkDestroyShaderModule(dev, vs, NULL);
    if (fs) vkDestroyShaderModule(dev, fs, NULL);
    if (vr != VK_SUCCESS)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot create the ray-event pipeline: %s",
                         leap_vk_result_name(vr));
    return LEAP_OK;
}

/* The shaders' specialisation constants (shaders/march.glsl). */
typedef struct spec_values {
    VkBool32 tf_precorrected; /* constant_id 0 */
    uint32_t mode;            /* constant_id 1 */
    VkBool32 labels;          /* constant_id 2 */
    VkBool32 mip;             /* constant_id 3 */
    VkBool32 shade;           /* constant_id 4 */
    VkBool32 page_middle;     /* constant_id 5 */
    uint32_t ray_pass;        /* constant_id 6: LEAP_RAY_PASS_IMAGE or a list, LEAP_RAYS_* (shared.h) */
    VkBool32 count_naive;     /* constant_id 7 (resolve) */
    VkBool32 cache;           /* constant_id 9 */
    VkBool32 skip_empty;      /* constant_id 10 */
} spec_values;

static leap_result create_compute(leap_renderer *r, VkShaderModule module, spec_values values, VkPipeline *out,
                                  leap_error *err)
{
    const VkSpecializationMapEntry entries[] = {
        {0, offsetof(spec_values, tf_precorrected), sizeof values.tf_precorrected},
        {1, offsetof(spec_values, mode), sizeof values.mode},
        {2, offsetof(spec_values, labels), sizeof values.labels},
        {3, offsetof(spec_values, mip), sizeof values.mip},
        {4, offsetof(spec_values, shade), sizeof values.shade},
        {5, offsetof(spec_values, page_middle), sizeof values.page_middle},
        {6, offsetof(spec_values, ray_pass), sizeof values.ray_pass},
        {7, offsetof(spec_values, count_naive), sizeof values.count_naive},
        {9, offsetof(spec_values, cache), sizeof values.cache},
        {10, offsetof(spec_values, skip_empty), sizeof values.skip_empty},
    };
    VkSpecializationInfo spec = {10, entries, sizeof values, &values};
    VkComputePipelineCreateInfo cpci = {
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .stage = {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                  .module = module, .pName = "main", .pSpecializationInfo = &spec},
        .layout = r->pipeline_layout,
    };
    VkResult vr = vkCreateComputePipelines(r->gpu->device, r->gpu->pipeline_cache, 1, &cpci, NULL, out);
    if (vr != VK_SUCCESS)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot create a compute pipeline: %s", leap_vk_result_name(vr));
    return LEAP_OK;
}

/* The raster's first pass (rects.comp), which has no specialisation constants. */
static leap_result create_rects_pipeline(leap_renderer *r, leap_error *err)
{
    VkShaderModule module = VK_NULL_HANDLE;
    VkResult vr = make_module(r->gpu->device, rects_spv, sizeof rects_spv, &module);
    if (vr != VK_SUCCESS)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot create a shader module: %s", leap_vk_result_name(vr));
    leap_result lr = create_compute(r, module, (spec_values){0}, &r->rects, err);
    vkDestroyShaderModule(r->gpu->device, module, NULL);
    return lr;
}

int renderer_composite_kind(const leap_renderer *r, const leap_march *m)
{
    if (r->labels) return COMPOSITE_LABELS;
    if (m->mip) return COMPOSITE_MIP;
    if (m->shade.on) return r->tf_precorrected ? COMPOSITE_SHADED_PRECORRECTED : COMPOSITE_SHADED_PER_SAMPLE;
    return r->tf_precorrected ? COMPOSITE_PRECORRECTED : COMPOSITE_PER_SAMPLE;
}

/* The pipeline cached at *slot, created on first use for these constants. `chord`: a sparseleap
 * frame's single chord, marched by the bbox mode's code. */
static leap_result cached_composite(leap_renderer *r, leap_mode mode, int chord, int kind, uint32_t ray_pass,
                                    VkPipeline *out, leap_error *err)
{
    const int volume = (r->mid_levels > 0) | (r->cache.capacity > 0) << 1;
    VkPipeline *slot = ray_pass == LEAP_RAYS_OVERFLOW ? &r->overflow[kind][volume]
                                                      : &r->composite[chord ? COMPOSITE_CHORD : mode][kind][volume];
    if (!*slot) {
        /* Label opacities are corrected for the step in the object table, like a precorrected
         * TF; MIP reads the table's opacities as they are (no step correction at all). */
        spec_values values = {kind == COMPOSITE_PRECORRECTED || kind == COMPOSITE_LABELS ||
                                  kind == COMPOSITE_SHADED_PRECORRECTED,
                              (uint32_t)mode, kind == COMPOSITE_LABELS, kind == COMPOSITE_MIP,
                              kind == COMPOSITE_SHADED_PER_SAMPLE || kind == COMPOSITE_SHADED_PRECORRECTED,
                              volume & 1, ray_pass, VK_FALSE, volume >> 1,
                              chord || mode == LEAP_RENDER_OCTREE || mode == LEAP_RENDER_SPARSELEAP};
        leap_result lr = create_compute(r, r->composite_module, values, slot, err);
        if (lr) return lr;
    }
    *out = *slot;
    return LEAP_OK;
}

/* Only long boxes' pipelines walk middle page levels: the walk costs 3-10 % of the frame in every
 * other one; only a brick cache's pipelines handle missing cells: 1-3.5 % (lavapipe, measured). */
leap_result renderer_composite_pipeline(leap_renderer *r, leap_mode mode, int chord, int kind, VkPipeline *out,
                                       leap_error *err)
{
    /* sparseleap marches the rays the resolve pass lists */
    const uint32_t pass = mode == LEAP_RENDER_SPARSELEAP ? LEAP_RAYS_MARCH : LEAP_RAY_PASS_IMAGE;
    return cached_composite(r, mode, chord, kind, pass, out, err);
}

leap_result renderer_overflow_pipeline(leap_renderer *r, int kind, VkPipeline *out, leap_error *err)
{
    return cached_composite(r, LEAP_RENDER_OCTREE, 0, kind, LEAP_RAYS_OVERFLOW, out, err);
}

leap_result renderer_resolve_pipelines(leap_renderer *r, VkPipeline stages[2], leap_error *err)
{
    const uint32_t pass[2] = {LEAP_RAY_PASS_IMAGE, LEAP_RAYS_EVENTS};
    for (int s = 0; s < 2; ++s) {
        VkPipeline *slot = &r->resolve[s][r->count_naive != 0];
        leap_result lr = LEAP_OK;
        if (!*slot)
            lr = create_compute(r, r->resolve_module, (spec_values){.ray_pass = pass[s], .count_naive = r->count_naive != 0},
                                slot, err);
        if (lr) return lr;
        stages[s] = *slot;
    }
    return LEAP_OK;
}

leap_result renderer_create_pipelines(leap_renderer *r, leap_error *err)
{
    VkDevice dev = r->gpu->device;
    VkDescriptorSetLayoutBinding b[BINDING_COUNT];
    VkShaderStageFlags all = VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
    for (uint32_t i = 0; i < BINDING_COUNT; ++i)
        b[i] = (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, NULL};
    b[LEAP_BINDING_FRAME].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    b[LEAP_BINDING_ATLAS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    b[LEAP_BINDING_TF].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    b[LEAP_BINDING_VALUE_GRADIENTS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    VkDescriptorSetLayoutCreateInfo dslci = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
        .bindingCount = BINDING_COUNT,
        .pBindings = b,
    };
    LEAP_VK_CHECK(vkCreateDescriptorSetLayout(dev, &dslci, NULL, &r->set_layout));
    VkPushConstantRange push = {VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(leap_push_gpu)};
    VkPipelineLayoutCreateInfo plci = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
        .setLayoutCount = 1,
        .pSetLayouts = &r->set_layout,
        .pushConstantRangeCount = 1,
        .pPushConstantRanges = &push,
    };
    LEAP_VK_CHECK(vkCreatePipelineLayout(dev, &plci, NULL, &r->pipeline_layout));
    VkResult mr = make_module(dev, composite_spv, sizeof composite_spv, &r->composite_module);
    if (mr == VK_SUCCESS) mr = make_module(dev, resolve_spv, sizeof resolve_spv, &r->resolve_module);
    leap_result lr = LEAP_OK;
    if (mr != VK_SUCCESS)
        lr = leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot create a shader module: %s", leap_vk_result_name(mr));
    if (!lr) lr = create_events_pipeline(r, err);
    if (!lr) lr = create_rects_pipeline(r, err);
    if (lr) return lr;
    VkSamplerCreateInfo sci = {
        .sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO,
        .magFilter = VK_FILTER_LINEAR,
        .minFilter = VK_FILTER_LINEAR,
        .mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST,
        .addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
        .addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
        .addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
        .maxLod = 0.0f,
    };
    LEAP_VK_CHECK(vkCreateSampler(dev, &sci, NULL, &r->linear_sampler));
    /* The atlas's: repeating (leap_cursor_seek addresses texels LEAP_ATLAS_EXTENT_MAX up). */
    sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    LEAP_VK_CHECK(vkCreateSampler(dev, &sci, NULL, &r->atlas_sampler));
    VkDescriptorPoolSize sizes[] = {
        {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
        {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 3},
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, BINDING_COUNT - 4},
    };
    VkDescriptorPoolCreateInfo dpci = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
        .maxSets = 1,
        .poolSizeCount = 3,
        .pPoolSizes = sizes,
    };
    LEAP_VK_CHECK(vkCreateDescriptorPool(dev, &dpci, NULL, &r->pool));
    VkDescriptorSetAllocateInfo dsai = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
        .descriptorPool = r->pool,
        .descriptorSetCount = 1,
        .pSetLayouts = &r->set_layout,
    };
    LEAP_VK_CHECK(vkAllocateDescriptorSets(dev, &dsai, &r->set));
    lr = leap_gpu_buffer_create(r->gpu, sizeof(leap_frame_gpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, &r->frame, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, sizeof(leap_box_gpu), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->boxes, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, 32, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->tree, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->objects, err);
    return lr;
}
