; The kitchen without its radishes (the variant planet solved in the thesis): the cabbages stand
; free on the shelf. Scene: kitchen_noradish.xml.
(define (problem kitchen-noradish)
   (:domain kitchen)
   (:objects
     shelf dining_table glass_place1 glass_place2 cabbage_place1 cabbage_place2 - surface
     glass1 glass2 cabbage1 cabbage2 - objs)
   (:init
          (on-surface glass1 dining_table) (on-surface glass2 dining_table)
          (on-surface cabbage1 shelf) (on-surface cabbage2 shelf)
          (arm-empty))
   (:goal (and
          (clean glass1) (clean glass2)
          (on-surface glass1 glass_place1) (on-surface glass2 glass_place2)
          (cooked cabbage1) (cooked cabbage2)
          (on-surface cabbage1 cabbage_place1) (on-surface cabbage2 cabbage_place2))))
