mat = gr.material({albedo = {0.8, 0.2, 0.1}, roughness = 0.4, metallic = gr.const(0.5)})
root = gr.node("root")
ball = gr.sphere("ball")
ball:set_material(mat)
ball:translate(0, 1, 0)
ball:rotate('y', 30)
root:add_child(ball)
box = gr.cube("box")
box:scale(2, 0.1, 2)
root:add_child(box)
blob = gr.sdf("blob", {type = "smooth_union", k = 0.1, {type = "sphere", radius = 0.5},
                       {type = "box", half_size = {1, 1, 1}, translate = {0, 1, 0}}}, {})
root:add_child(blob)
x = ease.between(0, 1, 0.5, ease.in_out_cubic)
gr.render{scene = root, output = "out.png", width = 8, height = 8, spp = 1,
          eye = {0, 2, 8}, view = {0, -0.2, -1}, up = {0, 1, 0}, fov = 40,
          lights = {gr.light({4, 6, 4}, {40, 40, 40})}, ambient = {0.1, 0.1, 0.1}}
