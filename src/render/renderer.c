/* Render core: Vulkan resources for one volume, transfer function and occupancy, and the
 * frame passes: ray events (raster), segment lists (resolve), compositing. */
#include "leap/renderer.h"
#include "util.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "leap/gpu.h"
#include "shared.h"

static const uint32_t composite_spv[] = {
#include "composite_comp.inc"
};
static const uint32_t resolve_spv[] = {
#include "resolve_comp.inc"
};
static const uint32_t events_vert_spv[] = {
#include "events_vert.inc"
};
static const uint32_t events_frag_spv[] = {
#include "events_frag.inc"
};


_Static_assert(sizeof(leap_frame_gpu) == 400, "leap_frame_gpu must match its std140 layout in shared.h");
_Static_assert(sizeof(leap_box_gpu) == 48, "leap_box_gpu must match its std430 layout in shared.h");
#define BINDING_COUNT 13
#define RASTER_GROW_PIXELS 0.25f      /* box growth for raster coverage (snapping is 1/256 px) */

enum { TS_START, TS_RASTER, TS_RESOLVE, TS_COMPOSITE, TS_COUNT };

struct leap_renderer {
    leap_gpu *gpu;
    char driver[2 * VK_MAX_DRIVER_NAME_SIZE];
    uint32_t pixel_events, max_segments;
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout pipeline_layout;
    VkPipeline resolve, events;
    /* The composite pass per mode and opacity correction (per sample [0], in the TF table
     * [1]): specialisation constants, so each pipeline holds only the code it runs. Created
     * on first use from composite_module. */
    VkShaderModule composite_module;
    VkPipeline composite[LEAP_RENDER_MODE_COUNT][2];
    VkRenderPass render_pass;
    VkFramebuffer framebuffer;
    uint32_t fb_width, fb_height;
    VkSampler linear_sampler;
    VkDescriptorPool pool;
    VkDescriptorSet set;
    leap_buffer frame;
    leap_image atlas;
    leap_buffer pages;
    leap_image tf;     /* tf_raw's table for step tf_step (no image: not uploaded yet) */
    leap_tf tf_raw;
    int has_tf;
    double tf_step;
    int tf_precorrected; /* the table's opacities are corrected for tf_step */
    leap_buffer out_rgba, out_aux;
    leap_buffer boxes, event_counts, event_t, event_key, segments, pixel_lists, tree;
    uint32_t tree_depth;
    int keep_lists;          /* build the lists even when the boxes reduce to one (dumps) */
    size_t pixels_allocated;
    /* From the uploaded atlas. */
    int has_volume;
    uint64_t atlas_serial;  /* the uploaded atlas (0: none or not from a scene binding) */
    leap_march domain;      /* its index origin and marching box */
    double value_min, value_max;
    uint32_t top_dims[3], top_count, slot_dims[3], block_shift;
    uint64_t float_atlas_max_bytes;
    uint32_t texel_bytes; /* 4: R32_SFLOAT, 2: R16_UNORM */
    /* Not owned. */
    const leap_occupancy *occupancy;
    const leap_boxes *box_set;
    int lists_valid;
};

const char *leap_mode_name(leap_mode mode)
{
    switch (mode) {
    case LEAP_RENDER_NAIVE: return "naive";
    case LEAP_RENDER_BBOX: return "bbox";
    case LEAP_RENDER_SPARSELEAP: return "sparseleap";
    case LEAP_RENDER_OCTREE: return "octree";
    default: return "unknown";
    }
}

int leap_mode_from_name(const char *name)
{
    for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m)
        if (name && strcmp(name, leap_mode_name((leap_mode)m)) == 0) return m;
    return -1;
}

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

/* The ray-event pass: boxes as instances, back faces only (chosen in the vertex shader),
 * no attachments: fragments only append to storage buffers. */
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
    VkPipelineShaderStageCreateInfo stages[2] = {
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, .stage = VK_SHADER_STAGE_VERTEX_BIT,
         .module = vs, .pName = "main"},
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
    if (vr == VK_SUCCESS) vr = vkCreateGraphicsPipelines(dev, VK_NULL_HANDLE, 1, &gpci, NULL, &r->events);
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
} spec_values;

static leap_result create_compute(leap_renderer *r, VkShaderModule module, spec_values values, VkPipeline *out,
                                  leap_error *err)
{
    const VkSpecializationMapEntry entries[] = {
        {0, offsetof(spec_values, tf_precorrected), sizeof values.tf_precorrected},
        {1, offsetof(spec_values, mode), sizeof values.mode},
    };
    VkSpecializationInfo spec = {2, entries, sizeof values, &values};
    VkComputePipelineCreateInfo cpci = {
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .stage = {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                  .module = module, .pName = "main", .pSpecializationInfo = &spec},
        .layout = r->pipeline_layout,
    };
    VkResult vr = vkCreateComputePipelines(r->gpu->device, VK_NULL_HANDLE, 1, &cpci, NULL, out);
    if (vr != VK_SUCCESS)
        return leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot create a compute pipeline: %s", leap_vk_result_name(vr));
    return LEAP_OK;
}

static leap_result composite_pipeline(leap_renderer *r, leap_mode mode, int precorrected, VkPipeline *out,
                                      leap_error *err)
{
    VkPipeline *p = &r->composite[mode][precorrected != 0];
    if (!*p) {
        spec_values values = {precorrected != 0, (uint32_t)mode};
        leap_result lr = create_compute(r, r->composite_module, values, p, err);
        if (lr) return lr;
    }
    *out = *p;
    return LEAP_OK;
}

static leap_result create_pipelines(leap_renderer *r, leap_error *err)
{
    VkDevice dev = r->gpu->device;
    VkDescriptorSetLayoutBinding b[BINDING_COUNT];
    VkShaderStageFlags all = VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
    for (uint32_t i = 0; i < BINDING_COUNT; ++i)
        b[i] = (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, all, NULL};
    b[LEAP_BINDING_FRAME].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    b[LEAP_BINDING_ATLAS].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    b[LEAP_BINDING_TF].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
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
    VkShaderModule resolve_module = VK_NULL_HANDLE;
    VkResult mr = make_module(dev, composite_spv, sizeof composite_spv, &r->composite_module);
    if (mr == VK_SUCCESS) mr = make_module(dev, resolve_spv, sizeof resolve_spv, &resolve_module);
    leap_result lr = LEAP_OK;
    if (mr != VK_SUCCESS)
        lr = leap_fail(err, LEAP_ERR_VULKAN, "Vulkan: cannot create a shader module: %s", leap_vk_result_name(mr));
    if (!lr) lr = create_compute(r, resolve_module, (spec_values){0, 0}, &r->resolve, err);
    if (resolve_module) vkDestroyShaderModule(dev, resolve_module, NULL);
    if (!lr) lr = create_events_pipeline(r, err);
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
    VkDescriptorPoolSize sizes[] = {
        {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
        {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2},
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, BINDING_COUNT - 3},
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
    return lr;
}

leap_result leap_renderer_create(const leap_renderer_desc *desc, leap_renderer **out, leap_error *err)
{
    *out = NULL;
    leap_renderer *r = calloc(1, sizeof *r);
    if (!r) return leap_fail(err, LEAP_ERR_OOM, "out of host memory");
    r->pixel_events = desc && desc->pixel_events ? desc->pixel_events : LEAP_PIXEL_EVENTS;
    r->keep_lists = desc && desc->keep_lists;
    if (r->pixel_events > LEAP_PIXEL_EVENTS) r->pixel_events = LEAP_PIXEL_EVENTS;
    if (r->pixel_events < 2) r->pixel_events = 2;
    r->max_segments = desc && desc->max_segments ? desc->max_segments : LEAP_MAX_SEGMENTS;
    if (r->max_segments > LEAP_MAX_SEGMENTS) r->max_segments = LEAP_MAX_SEGMENTS;
    r->float_atlas_max_bytes = desc && desc->float_atlas_max_bytes ? desc->float_atlas_max_bytes : LEAP_FLOAT_ATLAS_MAX_BYTES;
    leap_gpu_desc gd = {.device_name = desc ? desc->device_name : NULL};
    if (desc) {
        gd.instance_extensions = desc->instance_extensions;
        gd.instance_extension_count = desc->instance_extension_count;
        gd.swapchain = desc->swapchain;
    }
    leap_result lr = leap_gpu_create(&gd, &r->gpu, err);
    if (!lr) {
        snprintf(r->driver, sizeof r->driver, "%s %s", r->gpu->driver_name, r->gpu->driver_info);
        lr = create_pipelines(r, err);
    }
    if (lr) {
        leap_renderer_destroy(r);
        return lr;
    }
    *out = r;
    return LEAP_OK;
}

static void destroy_frame_buffers(leap_renderer *r)
{
    leap_gpu *gpu = r->gpu;
    leap_gpu_buffer_destroy(gpu, &r->out_aux);
    leap_gpu_buffer_destroy(gpu, &r->out_rgba);
    leap_gpu_buffer_destroy(gpu, &r->event_counts);
    leap_gpu_buffer_destroy(gpu, &r->event_t);
    leap_gpu_buffer_destroy(gpu, &r->event_key);
    leap_gpu_buffer_destroy(gpu, &r->segments);
    leap_gpu_buffer_destroy(gpu, &r->pixel_lists);
    if (r->framebuffer) vkDestroyFramebuffer(gpu->device, r->framebuffer, NULL);
    r->framebuffer = VK_NULL_HANDLE;
    r->pixels_allocated = 0;
    r->lists_valid = 0;
}

void leap_renderer_destroy(leap_renderer *r)
{
    if (!r) return;
    leap_gpu *gpu = r->gpu;
    if (gpu && gpu->device) {
        VkDevice dev = gpu->device;
        (void)vkDeviceWaitIdle(dev); /* tearing down: nothing to do about a failure */
        destroy_frame_buffers(r);
        leap_gpu_buffer_destroy(gpu, &r->tree);
        leap_gpu_buffer_destroy(gpu, &r->boxes);
        leap_gpu_image_destroy(gpu, &r->tf);
        leap_gpu_buffer_destroy(gpu, &r->pages);
        leap_gpu_image_destroy(gpu, &r->atlas);
        leap_gpu_buffer_destroy(gpu, &r->frame);
        if (r->pool) vkDestroyDescriptorPool(dev, r->pool, NULL);
        if (r->linear_sampler) vkDestroySampler(dev, r->linear_sampler, NULL);
        if (r->events) vkDestroyPipeline(dev, r->events, NULL);
        if (r->resolve) vkDestroyPipeline(dev, r->resolve, NULL);
        if (r->render_pass) vkDestroyRenderPass(dev, r->render_pass, NULL);
        for (int m = 0; m < LEAP_RENDER_MODE_COUNT; ++m)
            for (int i = 0; i < 2; ++i)
                if (r->composite[m][i]) vkDestroyPipeline(dev, r->composite[m][i], NULL);
        if (r->composite_module) vkDestroyShaderModule(dev, r->composite_module, NULL);
        if (r->pipeline_layout) vkDestroyPipelineLayout(dev, r->pipeline_layout, NULL);
        if (r->set_layout) vkDestroyDescriptorSetLayout(dev, r->set_layout, NULL);
    }
    leap_gpu_destroy(gpu);
    free(r);
}

struct leap_gpu *leap_renderer_gpu(leap_renderer *r) { return r->gpu; }
const char *leap_renderer_device_name(const leap_renderer *r) { return r->gpu->props.deviceName; }
const char *leap_renderer_driver_name(const leap_renderer *r) { return r->driver; }

/* Sample positions are floats relative to the atlas origin: beyond this many voxels from it
 * their rounding shows against the double reference (measured on a ball at 2^k voxels from
 * the origin, 96x96: RMSE 5.7e-5 at 2^16, 2.0e-4 at 2^18, 2.6e-3 at 2^22, 4.2e-2 at 2^24). */
#define LEAP_FLOAT_POSITION_LIMIT 131072.0

leap_result leap_renderer_set_volume(leap_renderer *r, const leap_atlas *atlas, leap_error *err)
{
    double reach = 0;
    for (int i = 0; i < 3; ++i) reach = fmax(reach, fmax(fabs(atlas->domain_min[i]), fabs(atlas->domain_max[i])));
    if (reach > LEAP_FLOAT_POSITION_LIMIT)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "the active box spans %.0f voxels along an axis; the GPU samples positions in float, which "
                         "holds the accuracy of the reference only within %.0f voxels of the box corner (use "
                         "--mode reference, or crop the grid)",
                         reach, LEAP_FLOAT_POSITION_LIMIT);
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    leap_gpu_image_destroy(r->gpu, &r->atlas);
    leap_gpu_buffer_destroy(r->gpu, &r->pages);
    r->has_volume = 0;
    r->atlas_serial = 0;
    size_t texels = (size_t)atlas->texel_dims[0] * atlas->texel_dims[1] * atlas->texel_dims[2];
    leap_result lr = LEAP_ERR_OOM;
    VkFormatProperties fp;
    vkGetPhysicalDeviceFormatProperties(r->gpu->physical, VK_FORMAT_R32_SFLOAT, &fp);
    int float_ok = (fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) &&
                   texels <= r->float_atlas_max_bytes / sizeof(float);
    float *values = float_ok ? malloc(texels * sizeof(float)) : NULL;
    if (values) {
        /* The same 16-bit values, decoded as the shader decodes a constant cell's. */
        for (size_t i = 0; i < texels; ++i) values[i] = (float)atlas->texels[i] * (float)(1.0 / 65535.0);
        r->texel_bytes = sizeof(float);
        lr = leap_gpu_image_create(r->gpu, VK_FORMAT_R32_SFLOAT, atlas->texel_dims, values, texels * sizeof(float),
                                   &r->atlas, err);
        free(values);
        if (lr) leap_gpu_image_destroy(r->gpu, &r->atlas);
    }
    if (lr) {
        /* Too large for float, not filterable, no host memory to convert, or the float image
         * did not fit on the device: 16 bits give the same values, slower. */
        r->texel_bytes = sizeof(uint16_t);
        lr = leap_gpu_image_create(r->gpu, VK_FORMAT_R16_UNORM, atlas->texel_dims, atlas->texels,
                                   texels * sizeof(uint16_t), &r->atlas, err);
    }
    if (!lr)
        lr = leap_gpu_buffer_create(r->gpu, atlas->page_words * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                    &r->pages, err);
    if (lr) return lr;
    memcpy(r->pages.mapped, atlas->pages, atlas->page_words * 4);
    r->value_min = atlas->value_min;
    r->value_max = atlas->value_max;
    for (int i = 0; i < 3; ++i) {
        r->top_dims[i] = atlas->top_dims[i];
        r->slot_dims[i] = atlas->slot_dims[i];
    }
    r->block_shift = atlas->block_shift;
    r->top_count = atlas->top_count;
    leap_atlas_march_domain(atlas, &r->domain);
    r->atlas_serial = atlas->serial;
    r->has_volume = 1;
    return LEAP_OK;
}

leap_result leap_renderer_bind_scene(leap_renderer *r, const leap_scene *scene, leap_error *err)
{
    leap_result lr = LEAP_OK;
    if (!r->has_volume || r->atlas_serial != scene->atlas->serial) lr = leap_renderer_set_volume(r, scene->atlas, err);
    if (!lr) lr = leap_renderer_set_tf(r, &scene->tf, err);
    if (lr) return lr;
    leap_renderer_set_occupancy(r, scene->occupancy, scene->boxes);
    return LEAP_OK;
}

leap_result leap_renderer_set_tf(leap_renderer *r, const leap_tf *tf, leap_error *err)
{
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    leap_gpu_image_destroy(r->gpu, &r->tf);
    r->tf_raw = *tf;
    r->has_tf = 1;
    return LEAP_OK;
}

/* The GPU table holds opacities corrected for the step where that is accurate enough, so it
 * is rebuilt when the step changes. */
static leap_result upload_tf(leap_renderer *r, double step, leap_error *err)
{
    if (r->tf.image && r->tf_step == step) return LEAP_OK;
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device)); /* the old table may be in use */
    size_t bytes = sizeof(float[LEAP_TF_GPU_TABLE_SIZE][4]);
    float(*table)[4] = malloc(bytes);
    if (!table) return leap_fail(err, LEAP_ERR_OOM, "renderer: out of host memory for the transfer function table");
    r->tf_precorrected = leap_tf_precorrect_ok(&r->tf_raw, step);
    leap_tf_gpu_table(&r->tf_raw, step, r->tf_precorrected, table);
    leap_gpu_image_destroy(r->gpu, &r->tf);
    uint32_t extent[3] = {LEAP_TF_GPU_TABLE_SIZE, 0, 0};
    leap_result lr = leap_gpu_image_create(r->gpu, VK_FORMAT_R32G32B32A32_SFLOAT, extent, table, bytes, &r->tf, err);
    free(table);
    if (!lr) r->tf_step = step; /* a failed upload leaves no table: the next frame retries */
    return lr;
}

void leap_renderer_set_occupancy(leap_renderer *r, const leap_occupancy *occ, const leap_boxes *boxes)
{
    r->occupancy = occ;
    r->box_set = boxes;
}

uint64_t leap_renderer_volume_bytes(const leap_renderer *r)
{
    if (!r->has_volume) return 0;
    return (uint64_t)r->atlas.extent[0] * r->atlas.extent[1] * r->atlas.extent[2] * r->texel_bytes + r->pages.size;
}

const char *leap_renderer_atlas_format(const leap_renderer *r)
{
    if (!r->has_volume) return NULL;
    return r->texel_bytes == sizeof(float) ? "R32_SFLOAT" : "R16_UNORM";
}

const uint32_t *leap_renderer_pixel_lists(const leap_renderer *r)
{
    return r->lists_valid ? r->pixel_lists.mapped : NULL;
}

uint32_t leap_renderer_pixel_events(const leap_renderer *r, int x, int y, leap_event *out, uint32_t cap)
{
    if (!r->lists_valid || x < 0 || y < 0 || (uint32_t)x >= r->fb_width || (uint32_t)y >= r->fb_height) return 0;
    size_t pixel = (size_t)y * r->fb_width + x;
    const uint32_t total = ((const uint32_t *)r->event_counts.mapped)[pixel];
    const float *t = (const float *)r->event_t.mapped + pixel * LEAP_PIXEL_EVENTS;
    const uint32_t *key = (const uint32_t *)r->event_key.mapped + pixel * LEAP_PIXEL_EVENTS;
    const uint32_t stored = total < r->pixel_events ? total : r->pixel_events;
    for (uint32_t n = 0; n < stored && n < cap; ++n) out[n] = (leap_event){t[n], key[n] >> 2, key[n] & 3u};
    return stored;
}

uint32_t leap_renderer_pixel_segments(const leap_renderer *r, int x, int y, leap_segment *out, uint32_t cap,
                                      int *overflow)
{
    if (overflow) *overflow = 0;
    if (!r->lists_valid || x < 0 || y < 0 || (uint32_t)x >= r->fb_width || (uint32_t)y >= r->fb_height) return 0;
    size_t pixel = (size_t)y * r->fb_width + x;
    const uint32_t *pl = (const uint32_t *)r->pixel_lists.mapped + 4 * pixel;
    const float *seg = (const float *)r->segments.mapped + 2 * pixel * r->max_segments;
    if (overflow) *overflow = (pl[0] & LEAP_PIXEL_OVERFLOW) != 0;
    uint32_t n = pl[0] & LEAP_PIXEL_COUNT_MASK;
    for (uint32_t i = 0; i < n && i < cap; ++i)
        out[i] = (leap_segment){seg[2 * i], seg[2 * i + 1], (pl[2] >> i) & 1u ? LEAP_CLASS_UNKNOWN : LEAP_CLASS_NONEMPTY};
    return n;
}

const leap_box_gpu *leap_renderer_boxes(const leap_renderer *r, uint32_t *count)
{
    *count = r->lists_valid && r->box_set ? leap_boxes_count(r->box_set) : 0;
    return r->boxes.mapped;
}

static leap_vec4 v4(const double v[3], double w)
{
    return (leap_vec4){(float)v[0], (float)v[1], (float)v[2], (float)w};
}

/* Rows of the matrix taking relative index space to clip space such that the pixel centre
 * (px, py) of the view's ray through a point lands on framebuffer position (px, py).
 * Perspective: (a, b, c) = [dir_dx dir_dy dir0]^-1 (X - origin0), pixel = (a/c, b/c).
 * Orthographic: (px, py, t) = [origin_dx origin_dy dir0]^-1 (X - origin0). */
static void clip_matrix(const leap_rays *v, leap_frame_gpu *f)
{
    double inv[3][3] = {{0}};
    const double *a = v->ortho ? v->origin_dx : v->dir_dx, *b = v->ortho ? v->origin_dy : v->dir_dy;
    const double cols[3][3] = {{a[0], b[0], v->dir0[0]}, {a[1], b[1], v->dir0[1]}, {a[2], b[2], v->dir0[2]}};
    leap__invert3(cols, inv);
    double rows[4][4];
    for (int i = 0; i < 3; ++i) {
        double off = -(inv[i][0] * v->origin0[0] + inv[i][1] * v->origin0[1] + inv[i][2] * v->origin0[2]);
        rows[i][0] = inv[i][0], rows[i][1] = inv[i][1], rows[i][2] = inv[i][2], rows[i][3] = off;
    }
    /* rows[0], rows[1] give pixel coordinates times w (perspective: w = rows[2]). */
    double w[4], sx = 2.0 / v->width, sy = 2.0 / v->height;
    for (int k = 0; k < 4; ++k) w[k] = v->ortho ? (k == 3 ? 1.0 : 0.0) : rows[2][k];
    double cx[4], cy[4];
    for (int k = 0; k < 4; ++k) {
        cx[k] = sx * rows[0][k] - w[k];
        cy[k] = sy * rows[1][k] - w[k];
    }
    f->clip_x = (leap_vec4){(float)cx[0], (float)cx[1], (float)cx[2], (float)cx[3]};
    f->clip_y = (leap_vec4){(float)cy[0], (float)cy[1], (float)cy[2], (float)cy[3]};
    f->clip_z = (leap_vec4){0, 0, 0, 0};
    f->clip_w = (leap_vec4){(float)w[0], (float)w[1], (float)w[2], (float)w[3]};
    /* Size of one pixel: per unit distance (perspective) or absolute (ortho). */
    double len0 = sqrt(v->dir0[0] * v->dir0[0] + v->dir0[1] * v->dir0[1] + v->dir0[2] * v->dir0[2]);
    double px_len = 0;
    for (int i = 0; i < 3; ++i) {
        double d = v->ortho ? fmax(fabs(v->origin_dx[i]), fabs(v->origin_dy[i])) : fmax(fabs(v->dir_dx[i]), fabs(v->dir_dy[i]));
        px_len += d * d;
    }
    px_len = sqrt(px_len);
    f->raster = (leap_vec4){(float)(v->ortho ? px_len : px_len / len0), RASTER_GROW_PIXELS, 0, 0};
}

/* Lattice indices one composite dispatch may take per ray, so that no invocation group
 * reaches the driver's loop limit (see LEAP_LOOP_ITERATIONS_SAFE). A group runs each loop as
 * long as its longest lane, so its iterations are at most the sum over its LEAP_SIMD_LANES
 * lanes, counting for each lane the once-through of loops it enters with nothing to do. One
 * lane taking n lattice indices of step dt crosses at most X = sqrt(3) n dt / 8 + 4 cells,
 * and so tree leaves. It runs n sample iterations plus:
 * - naive, bbox: the march loop's outer iteration and two inner-loop entries per cell;
 * - octree: per leaf, the visit, a descent of up to depth iterations, and the march loop's three;
 * - sparseleap: per segment (at most LEAP_MAX_SEGMENTS), the iteration and the loop's entry;
 *   an overflowed pixel walks the tree as octree does. */
static double chunk_indices(const leap_renderer *r, leap_mode mode, double step)
{
    double per_cell = 0, fixed = 8;
    if (mode == LEAP_RENDER_NAIVE || mode == LEAP_RENDER_BBOX)
        per_cell = 3;
    else
        per_cell = r->tree_depth + 6.0; /* octree: also overflowed sparseleap pixels */
    if (mode == LEAP_RENDER_SPARSELEAP) fixed += 2 * LEAP_MAX_SEGMENTS;
    const double per_lane = (double)LEAP_LOOP_ITERATIONS_SAFE / LEAP_SIMD_LANES;
    double n = floor((per_lane - fixed - 4 * per_cell) / (1 + sqrt(3.0) / LEAP_CELL * step * per_cell));
    return n < 1 ? 1 : n;
}

/* Lattice indices a ray can hold before float stops representing them exactly: the shader
 * computes t_j = t0 + j * dt with j a float, so j must stay below 2^24. */
#define LATTICE_INDEX_LIMIT 16777216.0

/* Dispatches needed: the most lattice indices any pixel's ray holds inside the domain box,
 * over the lattice indices per dispatch the frame holds (limits.z, from chunk_indices).
 * Computed per pixel on the host in double, with the box grown by a voxel plus a relative
 * margin so that float rounding on the GPU can only shorten a ray, never lengthen it past
 * the bound: a chunk beyond every ray's last index would do nothing. This is what the frame
 * really marches (a sparse grid whose box is long but thin costs what its rays cross), not
 * the box diagonal. Fails when a ray holds more indices than float can count. */
typedef struct chunk_rect {
    uint32_t x0, y0, x1, y1; /* pixels [x0, x1) x [y0, y1); empty if x0 >= x1 */
} chunk_rect;

static leap_result chunk_count(const leap_rays *view, const leap_march *m, const leap_frame_gpu *f,
                               uint32_t *count, chunk_rect **rects_out, leap_error *err)
{
    *count = 1;
    *rects_out = NULL;
    double box_lo[3], box_hi[3], centre[3], diag = 0;
    for (int i = 0; i < 3; ++i) {
        if (!(m->domain_min[i] <= m->domain_max[i])) return LEAP_OK;
        box_lo[i] = m->domain_min[i];
        box_hi[i] = m->domain_max[i];
        centre[i] = 0.5 * (box_lo[i] + box_hi[i]);
        diag += (box_hi[i] - box_lo[i]) * (box_hi[i] - box_lo[i]);
    }
    diag = sqrt(diag);
    /* The grown box's diagonal bounds every pixel's chord (rays are unit length in index
     * space; origins are linear in the pixel, so the image corners bound their size). When
     * that bound fits one dispatch, every ray does and the per-pixel pass below is skipped:
     * the usual frame pays nothing for it. */
    double far_bound = diag;
    for (int a = 0; a < 3; ++a) {
        double o_abs = 0, o[3], d[3];
        for (int corner = 0; corner < 4; ++corner) {
            leap_rays_at(view, corner & 1 ? view->width : 0, corner & 2 ? view->height : 0, o, d);
            o_abs = fmax(o_abs, fabs(o[a]));
        }
        far_bound += o_abs + fabs(centre[a]) + o_abs + fabs(centre[a]);
    }
    double chord_bound = diag + 2 * sqrt(3.0) * (1.0 + 1e-5 * far_bound);
    double n_bound = ((chord_bound + m->step) / m->step + 2) * (1 + 1e-5) + 2;
    if (n_bound <= f->limits.z) return LEAP_OK;
    const size_t pixels = (size_t)view->width * view->height;
    uint32_t *need = malloc(pixels * sizeof *need); /* dispatches each pixel's ray needs */
    if (!need) return leap_fail(err, LEAP_ERR_OOM, "out of host memory for %zu pixels", pixels);
    double most = 0; /* lattice indices of the longest ray */
    uint32_t chunks = 1;
    for (int py = 0; py < view->height; ++py)
        for (int px = 0; px < view->width; ++px) {
            double o[3], d[3];
            leap_rays_at(view, px + 0.5, py + 0.5, o, d);
            /* Grown by more than the float error of the GPU's ray over any t up to the far
             * side of the box (relative 1e-5 of the coordinates involved, plus a voxel). */
            double far = diag, lo[3], hi[3];
            for (int a = 0; a < 3; ++a) far += fabs(o[a] - centre[a]) + fabs(o[a]) + fabs(centre[a]);
            for (int a = 0; a < 3; ++a) {
                lo[a] = box_lo[a] - (1.0 + 1e-5 * far);
                hi[a] = box_hi[a] + (1.0 + 1e-5 * far);
            }
            double t0 = 0, t1 = INFINITY;
            int hit = 1;
            for (int a = 0; a < 3 && hit; ++a) {
                if (d[a] == 0) {
                    hit = o[a] >= lo[a] && o[a] <= hi[a];
                } else {
                    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
                    t0 = fmax(t0, fmin(ta, tb));
                    t1 = fmin(t1, fmax(ta, tb));
                }
            }
            double n = 0;
            if (hit && t0 <= t1) n = ((t1 - floor(t0 / m->step) * m->step) / m->step + 2) * (1 + 1e-5) + 2;
            if (n > most) most = n;
            double k = n > LATTICE_INDEX_LIMIT ? 0 : ceil(n / f->limits.z);
            need[(size_t)py * view->width + px] = k < 1 ? 1 : (uint32_t)k;
            if (k > chunks) chunks = (uint32_t)k;
        }
    if (most > LATTICE_INDEX_LIMIT) {
        free(need);
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "a ray crosses %.4g samples of step %g inside the volume box; the GPU counts "
                         "lattice samples in float, exactly only up to 2^24 = 16777216 per ray (use a "
                         "larger --step or a view that crosses less of the box)",
                         most, m->step);
    }
    /* rects[c]: the pixels whose rays need more than c dispatches (chunk c marches them). */
    chunk_rect *rects = malloc(chunks * sizeof *rects);
    if (!rects) {
        free(need);
        return leap_fail(err, LEAP_ERR_OOM, "out of host memory for %u composite chunks", chunks);
    }
    for (uint32_t c = 0; c < chunks; ++c) rects[c] = (chunk_rect){UINT32_MAX, UINT32_MAX, 0, 0};
    for (uint32_t py = 0; py < (uint32_t)view->height; ++py)
        for (uint32_t px = 0; px < (uint32_t)view->width; ++px) {
            chunk_rect *q = &rects[need[(size_t)py * view->width + px] - 1];
            if (px < q->x0) q->x0 = px;
            if (py < q->y0) q->y0 = py;
            if (px + 1 > q->x1) q->x1 = px + 1;
            if (py + 1 > q->y1) q->y1 = py + 1;
        }
    free(need);
    for (uint32_t c = chunks - 1; c-- > 0;) { /* union with every later chunk's rectangle */
        chunk_rect *q = &rects[c], *n = &rects[c + 1];
        if (n->x0 < q->x0) q->x0 = n->x0;
        if (n->y0 < q->y0) q->y0 = n->y0;
        if (n->x1 > q->x1) q->x1 = n->x1;
        if (n->y1 > q->y1) q->y1 = n->y1;
    }
    rects[0] = (chunk_rect){0, 0, (uint32_t)view->width, (uint32_t)view->height}; /* every pixel is written */
    *count = chunks;
    *rects_out = rects;
    return LEAP_OK;
}

/* 2^k nearest to the length of v (k = 0 for a zero or non-finite length). */
static int pow2_exponent(const double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(l > 0) || !isfinite(l)) return 0;
    return (int)lrint(log2(l));
}

/* Power-of-two exponents that bring the frame's ray directions and index-to-world rows near
 * unit length, where float squares them without overflow or underflow (voxel sizes from
 * about 1e-19 and 1e19 on, GPU rays had length 0 or inf). Zero while the lengths are
 * within 2^-16..2^16, so ordinary grids send the very same floats. Scaling a ray's
 * direction by a power of two changes neither its normalised direction nor any pixel's
 * footprint (the clip matrix scales inversely, w with it); the depth is scaled back. */
#define FRAME_SCALE_FREE 16

static int frame_dir_exponent(const leap_rays *v)
{
    int k = pow2_exponent(v->dir0);
    return abs(k) <= FRAME_SCALE_FREE ? 0 : k;
}

static int frame_world_exponent(const leap_rays *v)
{
    int k = 0;
    for (int i = 0; i < 3; ++i) {
        int e = pow2_exponent(v->index_to_world_linear[i]);
        if (abs(e) > abs(k)) k = e;
    }
    return abs(k) <= FRAME_SCALE_FREE ? 0 : k;
}

static void fill_frame(const leap_renderer *r, const leap_rays *view_in, const leap_march *m, leap_mode mode,
                       uint32_t box_count, leap_frame_gpu *f)
{
    memset(f, 0, sizeof *f);
    leap_rays scaled = *view_in;
    const leap_rays *view = &scaled;
    const int kd = frame_dir_exponent(view_in), kw = frame_world_exponent(view_in);
    for (int c = 0; c < 3; ++c) {
        scaled.dir0[c] = ldexp(scaled.dir0[c], -kd);
        scaled.dir_dx[c] = ldexp(scaled.dir_dx[c], -kd);
        scaled.dir_dy[c] = ldexp(scaled.dir_dy[c], -kd);
        for (int i = 0; i < 3; ++i) scaled.index_to_world_linear[i][c] = ldexp(scaled.index_to_world_linear[i][c], -kw);
    }
    f->origin0 = v4(view->origin0, 0);
    f->origin_dx = v4(view->origin_dx, 0);
    f->origin_dy = v4(view->origin_dy, 0);
    f->dir0 = v4(view->dir0, 0);
    f->dir_dx = v4(view->dir_dx, 0);
    f->dir_dy = v4(view->dir_dy, 0);
    f->world_row0 = v4(view->index_to_world_linear[0], 0);
    f->world_row1 = v4(view->index_to_world_linear[1], 0);
    f->world_row2 = v4(view->index_to_world_linear[2], 0);
    f->domain_min = v4(m->domain_min, 0);
    f->domain_max = v4(m->domain_max, 0);
    f->atlas_inv_size = (leap_vec4){1.0f / r->atlas.extent[0], 1.0f / r->atlas.extent[1],
                                    1.0f / r->atlas.extent[2], 0};
    double range = m->range_hi - m->range_lo;
    double scale = range != 0 ? (r->value_max - r->value_min) / range : 0.0;
    double offset = range != 0 ? (r->value_min - m->range_lo) / range : 0.0;
    f->march = (leap_vec4){(float)m->step, (float)(m->step / LEAP_TF_STEP_REF), (float)scale, (float)offset};
    /* A precorrected table's opacities are compared with a threshold corrected alike. */
    double depth_opacity = r->tf_precorrected ? leap_tf_alpha_for_step(LEAP_DEPTH_OPACITY, m->step) : LEAP_DEPTH_OPACITY;
    f->limits = (leap_vec4){(float)LEAP_ERT_TRANSMITTANCE, (float)depth_opacity,
                            (float)chunk_indices(r, mode, m->step), (float)ldexp(1.0, kw)};
    f->top_dims = (leap_uvec4){r->top_dims[0], r->top_dims[1], r->top_dims[2], r->top_count};
    f->slot_dims = (leap_uvec4){r->slot_dims[0], r->slot_dims[1], r->slot_dims[2], r->block_shift};
    f->image = (leap_uvec4){(uint32_t)view->width, (uint32_t)view->height, 0, (uint32_t)view->ortho};
    clip_matrix(view, f);
    double lo[3] = {1, 1, 1}, hi[3] = {0, 0, 0}; /* empty unless the occupancy says otherwise */
    if (r->occupancy) leap_occupancy_nonempty_bounds(r->occupancy, lo, hi);
    f->bbox_min = v4(lo, 0);
    f->bbox_max = v4(hi, 0);
    f->lists = (leap_uvec4){r->pixel_events, r->max_segments, box_count, r->tree_depth};
}

static leap_result ensure_frame_buffers(leap_renderer *r, const leap_rays *view, leap_error *err)
{
    size_t pixels = (size_t)view->width * view->height;
    const uint64_t limit = r->gpu->storage_buffer_range;
    if ((uint64_t)pixels * 16 > limit || (uint64_t)pixels * r->max_segments * 8 > limit ||
        (uint64_t)pixels * LEAP_PIXEL_EVENTS * 4 > limit)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED,
                         "image of %dx%d pixels exceeds the device's %llu MiB per-buffer limit (at most %u pixels)",
                         view->width, view->height, (unsigned long long)(limit >> 20),
                         (unsigned)(limit / (8 * r->max_segments)));
    if (r->pixels_allocated >= pixels && r->fb_width == (uint32_t)view->width && r->fb_height == (uint32_t)view->height)
        return LEAP_OK;
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    destroy_frame_buffers(r);
    VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    leap_result lr = leap_gpu_buffer_create(r->gpu, pixels * 16, usage, &r->out_rgba, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * 16, usage, &r->out_aux, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * 4, usage, &r->event_counts, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * LEAP_PIXEL_EVENTS * 4, usage, &r->event_t, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * LEAP_PIXEL_EVENTS * 4, usage, &r->event_key, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * r->max_segments * 8, usage, &r->segments, err);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, pixels * 16, usage, &r->pixel_lists, err);
    if (lr) return lr;
    VkFramebufferCreateInfo fci = {
        .sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO,
        .renderPass = r->render_pass,
        .width = (uint32_t)view->width,
        .height = (uint32_t)view->height,
        .layers = 1,
    };
    LEAP_VK_CHECK(vkCreateFramebuffer(r->gpu->device, &fci, NULL, &r->framebuffer));
    r->fb_width = (uint32_t)view->width;
    r->fb_height = (uint32_t)view->height;
    r->pixels_allocated = pixels;
    return LEAP_OK;
}

static leap_result ensure_boxes(leap_renderer *r, uint32_t count, leap_error *err)
{
    VkDeviceSize need = (VkDeviceSize)(count ? count : 1) * sizeof(leap_box_gpu);
    if (need > r->gpu->storage_buffer_range)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "%u occupancy boxes exceed the device's %llu MiB buffer limit", count,
                         (unsigned long long)(r->gpu->storage_buffer_range >> 20));
    if (r->boxes.size >= need) return LEAP_OK;
    LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
    leap_gpu_buffer_destroy(r->gpu, &r->boxes);
    return leap_gpu_buffer_create(r->gpu, need, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->boxes, err);
}

/* Uploads the occupancy tree as it is classified now (octree mode, and sparseleap pixels whose
 * lists overflowed). */
static leap_result upload_tree(leap_renderer *r, leap_error *err)
{
    size_t words = leap_occupancy_flatten(r->occupancy, NULL, 0, &r->tree_depth);
    if (words == 0) return leap_fail(err, LEAP_ERR_OOM, "out of memory for the occupancy tree");
    if (words * 4 > r->gpu->storage_buffer_range)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "occupancy tree of %zu nodes exceeds the device's %llu MiB buffer limit",
                         words / 8, (unsigned long long)(r->gpu->storage_buffer_range >> 20));
    if (r->tree.size < words * 4) {
        LEAP_VK_CHECK(vkDeviceWaitIdle(r->gpu->device));
        leap_gpu_buffer_destroy(r->gpu, &r->tree);
        leap_result lr = leap_gpu_buffer_create(r->gpu, words * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->tree, err);
        if (lr) return lr;
    }
    leap_occupancy_flatten(r->occupancy, r->tree.mapped, words, &r->tree_depth);
    return LEAP_OK;
}

static void write_descriptors(leap_renderer *r)
{
    VkDescriptorBufferInfo buf[BINDING_COUNT];
    const leap_buffer *src[BINDING_COUNT] = {
        [LEAP_BINDING_FRAME] = &r->frame, [LEAP_BINDING_PAGES] = &r->pages,
        [LEAP_BINDING_OUT_RGBA] = &r->out_rgba, [LEAP_BINDING_OUT_AUX] = &r->out_aux,
        [LEAP_BINDING_BOXES] = &r->boxes, [LEAP_BINDING_EVENT_COUNTS] = &r->event_counts,
        [LEAP_BINDING_EVENT_T] = &r->event_t, [LEAP_BINDING_EVENT_KEY] = &r->event_key,
        [LEAP_BINDING_SEGMENTS] = &r->segments, [LEAP_BINDING_PIXELS] = &r->pixel_lists,
        [LEAP_BINDING_TREE] = &r->tree,
    };
    VkDescriptorImageInfo img[2] = {
        {r->linear_sampler, r->atlas.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
        {r->linear_sampler, r->tf.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
    };
    VkWriteDescriptorSet w[BINDING_COUNT];
    for (uint32_t i = 0; i < BINDING_COUNT; ++i) {
        w[i] = (VkWriteDescriptorSet){
            .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
            .dstSet = r->set,
            .dstBinding = i,
            .descriptorCount = 1,
            .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
        };
        if (i == LEAP_BINDING_ATLAS || i == LEAP_BINDING_TF) {
            w[i].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
            w[i].pImageInfo = &img[i == LEAP_BINDING_TF];
            continue;
        }
        if (i == LEAP_BINDING_FRAME) w[i].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        buf[i] = (VkDescriptorBufferInfo){src[i]->buffer, 0, VK_WHOLE_SIZE};
        w[i].pBufferInfo = &buf[i];
    }
    vkUpdateDescriptorSets(r->gpu->device, BINDING_COUNT, w, 0, NULL);
}

static void shader_barrier(VkCommandBuffer cmd, VkPipelineStageFlags src, VkPipelineStageFlags dst, VkAccessFlags from,
                           VkAccessFlags to)
{
    VkMemoryBarrier mb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER, .srcAccessMask = from, .dstAccessMask = to};
    vkCmdPipelineBarrier(cmd, src, dst, 0, 1, &mb, 0, NULL, 0, NULL);
}

static void record_lists(leap_renderer *r, const leap_rays *view, uint32_t box_count)
{
    VkCommandBuffer cmd = r->gpu->cmd;
    size_t pixels = (size_t)view->width * view->height;
    vkCmdFillBuffer(cmd, r->event_counts.buffer, 0, pixels * 4, 0);
    shader_barrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                   VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
    VkRenderPassBeginInfo rpbi = {
        .sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO,
        .renderPass = r->render_pass,
        .framebuffer = r->framebuffer,
        .renderArea = {{0, 0}, {(uint32_t)view->width, (uint32_t)view->height}},
    };
    vkCmdBeginRenderPass(cmd, &rpbi, VK_SUBPASS_CONTENTS_INLINE);
    VkViewport vp = {0, 0, (float)view->width, (float)view->height, 0, 1};
    VkRect2D sc = {{0, 0}, {(uint32_t)view->width, (uint32_t)view->height}};
    vkCmdSetViewport(cmd, 0, 1, &vp);
    vkCmdSetScissor(cmd, 0, 1, &sc);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r->events);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r->pipeline_layout, 0, 1, &r->set, 0, NULL);
    if (box_count) vkCmdDraw(cmd, 6, box_count, 0, 0);
    vkCmdEndRenderPass(cmd);
    if (r->gpu->timestamps)
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, r->gpu->timestamps, TS_RASTER);
    shader_barrier(cmd, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                   VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, r->resolve);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, r->pipeline_layout, 0, 1, &r->set, 0, NULL);
    vkCmdDispatch(cmd, ((uint32_t)view->width + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP,
                  ((uint32_t)view->height + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP, 1);
    if (r->gpu->timestamps)
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, r->gpu->timestamps, TS_RESOLVE);
    shader_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                   VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT);
}

leap_result leap_renderer_render(leap_renderer *r, const leap_rays *view, const leap_march *march_in,
                                 leap_mode mode, float *rgba, float *depth, float *samples,
                                 leap_frame_stats *stats, leap_error *err)
{
    leap_frame_stats st = {0};
    if (!r->has_volume || !r->has_tf)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: no volume or transfer function uploaded");
    if (!view || !march_in || view->width <= 0 || view->height <= 0)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: invalid view");
    if (!(march_in->step > 0) || !isfinite(march_in->step))
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: step must be a positive number");
    for (int i = 0; i < 3; ++i)
        if (view->index_origin[i] != r->domain.index_origin[i])
            return leap_fail(err, LEAP_ERR_USAGE, "renderer: the rays were made for another volume (index origin "
                             "%g,%g,%g, uploaded volume's %g,%g,%g)", view->index_origin[0], view->index_origin[1],
                             view->index_origin[2], r->domain.index_origin[0], r->domain.index_origin[1],
                             r->domain.index_origin[2]);
    /* Step and range are the caller's; the marching box is the uploaded atlas's. */
    leap_march domain_march = r->domain;
    domain_march.step = march_in->step;
    domain_march.range_lo = march_in->range_lo;
    domain_march.range_hi = march_in->range_hi;
    const leap_march *march = &domain_march;
    if ((int)mode < 0 || mode >= LEAP_RENDER_MODE_COUNT)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: unknown mode %d", (int)mode);
    if (mode != LEAP_RENDER_NAIVE && !r->occupancy)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: mode %s needs an occupancy", leap_mode_name(mode));
    int lists = mode == LEAP_RENDER_SPARSELEAP;
    if (lists && !r->box_set)
        return leap_fail(err, LEAP_ERR_USAGE, "renderer: sparseleap needs occupancy boxes");
    /* Boxes that reduce to at most one NONEMPTY box (the cut found nothing worth skipping inside
     * it) give every pixel at most one segment: the ray's chord through that box. The
     * composite pass computes it directly (the bbox pipeline with that box), with no raster or
     * resolve; keep_lists (dumps) builds the lists anyway. */
    uint32_t box_count = lists ? leap_boxes_count(r->box_set) : 0;
    int chord = lists && !r->keep_lists && box_count <= 1;
    size_t pixels = (size_t)view->width * view->height;
    double t0 = leap__now_ms();
    leap_result lr = ensure_frame_buffers(r, view, err);
    if (!lr) lr = upload_tf(r, march->step, err);
    if (!lr && lists) lr = ensure_boxes(r, box_count, err);
    if (lr) return lr;
    if (lists) {
        double eye_or_dir[3];
        /* The float values the GPU sees, so both agree on which side of a node plane the eye is. */
        for (int i = 0; i < 3; ++i) eye_or_dir[i] = (double)(float)(view->ortho ? view->dir0[i] : view->origin0[i]);
        st.order_ms = leap_boxes_order(r->box_set, eye_or_dir, view->ortho, r->boxes.mapped, NULL);
        st.boxes = box_count;
        if (chord && box_count == 1 && ((const leap_box_gpu *)r->boxes.mapped)[0].info.z != LEAP_CLASS_NONEMPTY)
            chord = 0; /* one UNKNOWN box: its segment must be listed as UNKNOWN */
    }
    /* The tree is walked by octree and by sparseleap pixels whose lists overflow (not in a chord frame). */
    if ((mode == LEAP_RENDER_OCTREE || (lists && !chord)) && (lr = upload_tree(r, err))) return lr;
    const leap_mode pass_mode = chord ? LEAP_RENDER_BBOX : mode;
    VkPipeline composite = VK_NULL_HANDLE;
    if ((lr = composite_pipeline(r, pass_mode, r->tf_precorrected, &composite, err))) return lr;
    fill_frame(r, view, march, pass_mode, box_count, r->frame.mapped);
    if (chord) {
        leap_frame_gpu *f = r->frame.mapped;
        const leap_box_gpu *b = r->boxes.mapped;
        f->bbox_min = box_count ? b->lo : (leap_vec4){1, 1, 1, 0}; /* no box: an empty one */
        f->bbox_max = box_count ? b->hi : (leap_vec4){0, 0, 0, 0};
        st.single_box = 1;
    }
    chunk_rect *rects = NULL;
    if ((lr = chunk_count(view, march, r->frame.mapped, &st.composite_chunks, &rects, err))) return lr;
    write_descriptors(r);
    double t1 = leap__now_ms();
    st.upload_ms = t1 - t0;

    leap_gpu *gpu = r->gpu;
    if ((lr = leap_gpu_begin(gpu, err))) {
        free(rects);
        return lr;
    }
    VkCommandBuffer cmd = gpu->cmd;
    if (gpu->timestamps) {
        vkCmdResetQueryPool(cmd, gpu->timestamps, 0, TS_COUNT);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, gpu->timestamps, TS_START);
    }
    if (lists && !chord) {
        record_lists(r, view, box_count);
    } else if (gpu->timestamps) {
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, gpu->timestamps, TS_RASTER);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, gpu->timestamps, TS_RESOLVE);
    }
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, composite);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, r->pipeline_layout, 0, 1, &r->set, 0, NULL);
    st.tf_precorrected = r->tf_precorrected;
    for (uint32_t chunk = 0; chunk < st.composite_chunks; ++chunk) {
        chunk_rect q = rects ? rects[chunk] : (chunk_rect){0, 0, (uint32_t)view->width, (uint32_t)view->height};
        if (q.x0 >= q.x1 || q.y0 >= q.y1) continue;
        if (chunk > 0)
            shader_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                           VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
        leap_push_gpu push = {.chunk = chunk, .pixel_x = q.x0, .pixel_y = q.y0};
        vkCmdPushConstants(cmd, r->pipeline_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
        vkCmdDispatch(cmd, (q.x1 - q.x0 + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP,
                      (q.y1 - q.y0 + LEAP_COMPOSITE_GROUP - 1) / LEAP_COMPOSITE_GROUP, 1);
    }
    free(rects);
    if (gpu->timestamps)
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, gpu->timestamps, TS_COMPOSITE);
    shader_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                   VK_ACCESS_HOST_READ_BIT);
    if ((lr = leap_gpu_submit_wait(gpu, err))) return lr;
    double t2 = leap__now_ms();
    st.render_ms = t2 - t1;
    double ts[TS_COUNT];
    if (gpu->timestamps && leap_gpu_read_timestamps(gpu, TS_COUNT, ts, err) == LEAP_OK) {
        st.gpu_raster_ms = ts[TS_RASTER];
        st.gpu_resolve_ms = ts[TS_RESOLVE] - ts[TS_RASTER];
        st.gpu_composite_ms = ts[TS_COMPOSITE] - ts[TS_RESOLVE];
    }

    const float *out = r->out_rgba.mapped, *aux = r->out_aux.mapped;
    if (rgba) memcpy(rgba, out, pixels * 4 * sizeof(float));
    uint64_t events = 0, segs = 0;
    const uint32_t *pl = r->pixel_lists.mapped;
    for (size_t i = 0; i < pixels; ++i) {
        uint32_t n = (uint32_t)aux[4 * i + 1];
        st.total_samples += n;
        st.naive_samples += (uint64_t)aux[4 * i + 2];
        if (n > st.samples_max) st.samples_max = n;
        if (depth) depth[i] = aux[4 * i];
        if (samples) samples[i] = aux[4 * i + 1];
        if (lists && !chord) {
            uint32_t e = pl[4 * i + 1], s = pl[4 * i] & LEAP_PIXEL_COUNT_MASK;
            events += e;
            segs += s;
            if (e > st.events_max) st.events_max = e;
            if (s > st.segments_max) st.segments_max = s;
            st.overflow_pixels += (pl[4 * i] & LEAP_PIXEL_OVERFLOW) != 0;
        }
    }
    r->lists_valid = lists && !chord;
    st.readback_ms = leap__now_ms() - t2;
    st.samples_mean = (double)st.total_samples / (double)pixels;
    st.events_mean = (double)events / (double)pixels;
    st.segments_mean = (double)segs / (double)pixels;
    st.width = (uint32_t)view->width;
    st.height = (uint32_t)view->height;
    if (stats) *stats = st;
    return LEAP_OK;
}
