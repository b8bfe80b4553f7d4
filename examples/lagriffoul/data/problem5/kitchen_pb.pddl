; The kitchen (problem 5), full: clean the 2 glasses and set them on their places; clean, cook
; and set the 2 cabbages, which stand on the shelf behind 2 radishes; the radishes end where
; they started (their spots on the shelf). Scene: kitchen.xml.
(define (problem kitchen)
   (:domain kitchen)
   (:objects
     shelf dining_table glass_place1 glass_place2 cabbage_place1 cabbage_place2
     radish_spot1 radish_spot2 - surface
     glass1 glass2 cabbage1 cabbage2 radish1 radish2 - objs)
   (:init
          (on-surface glass1 dining_table) (on-surface glass2 dining_table)
          (on-surface cabbage1 shelf) (on-surface cabbage2 shelf)
          (on-surface radish1 radish_spot1) (on-surface radish2 radish_spot2)
          (arm-empty))
   (:goal (and
          (clean glass1) (clean glass2)
          (on-surface glass1 glass_place1) (on-surface glass2 glass_place2)
          (cooked cabbage1) (cooked cabbage2)
          (on-surface cabbage1 cabbage_place1) (on-surface cabbage2 cabbage_place2)
          (on-surface radish1 radish_spot1) (on-surface radish2 radish_spot2))))
