//! From the image to the robot: with two cameras, how high a matched part stands
//! ([`stereo`]: disparity of its outline between the rectified views, then height from the
//! baseline and focal length), and the fit from image to robot coordinates
//! ([`calibrate`]). Both run after recognition, on the detections, and use fixed-size buffers.

pub mod calibrate;
pub mod stereo;
