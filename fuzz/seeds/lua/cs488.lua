red = gr.material({albedo = gr.const(1, 0, 0)})
scene = gr.node("scene")
for i = 1, 3 do
  local s = gr.sphere("s" .. i)
  s:translate(i, 0, 0)
  s:set_material(red)
  scene:add_child(s)
end
cam = gr.camera{eye = {0, 0, 5}, target = {0, 0, 0}, up = {0, 1, 0}, fov = 50}
gr.render(scene, "cs488.png", 4, 4, {0, 0, 5}, {0, 0, -1}, {0, 1, 0}, 50, {0.2, 0.2, 0.2},
          {gr.light({0, 5, 0}, {10, 10, 10}, {1, 0, 0})})
